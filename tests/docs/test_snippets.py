"""Every Python code block of the README runs on its own, and every docs page's blocks run
in order (a page builds up, e.g. the tutorial); the README keeps its quick-start block."""

import pathlib
import re

import pytest

ROOT = pathlib.Path(__file__).parents[2]
PAGES = sorted((ROOT / "docs").rglob("*.md"))


def _blocks(path):
    return re.findall(r"```python\n(.*?)```", path.read_text(), flags=re.S)


def test_readme_quick_start_is_the_two_commands():
    text = (ROOT / "README.md").read_text()
    block = re.search(r"## Quick start\n\n```\n(.*?)```", text, flags=re.S).group(1)
    assert block.splitlines() == ['pip install . && dmoc demo',
                                  'pip install ".[test]" && python -m pytest']
    assert 'pip install ".[test]" && python -m pytest' in (ROOT / ".ci" / "run").read_text()


@pytest.mark.parametrize("index", range(len(_blocks(ROOT / "README.md"))))
def test_readme_block_runs_alone(index, tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    exec(compile(_blocks(ROOT / "README.md")[index], "README.md", "exec"), {})


@pytest.mark.parametrize("page", [p for p in PAGES if _blocks(p)], ids=lambda p: p.stem)
def test_docs_page_blocks_run(page, tmp_path, monkeypatch, capsys):
    monkeypatch.chdir(tmp_path)
    namespace = {}
    for block in _blocks(page):
        exec(compile(block, str(page), "exec"), namespace)
    assert capsys.readouterr().out      # every page prints what it shows
