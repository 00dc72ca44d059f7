"""The outputs docs/tutorial.md shows are what its code prints: each ```text block after a
```python block is compared with that block's output, numbers at the precision shown
(round-off figures, below 1e-12, only as round-off), the rest word for word; and the
figures it shows exist.

Oracle: the page's own text, against running the page."""

import contextlib
import io
import math
import pathlib
import re

import pytest

DOCS = pathlib.Path(__file__).parents[2] / "docs"
PAGE = (DOCS / "tutorial.md").read_text()
NUMBER = re.compile(r"[-+]?\d+\.?\d*(?:e[-+]?\d+)?")


def _blocks():
    """[(code, shown output or None)] of the page, in order."""
    fences = re.findall(r"```(\w*|\{image\}[^\n]*)\n(.*?)```", PAGE, flags=re.S)
    return [(body, fences[i + 1][1] if i + 1 < len(fences) and fences[i + 1][0] == "text" else None)
            for i, (language, body) in enumerate(fences) if language == "python"]


def _agree(shown, printed):
    """Same words; each number as shown to its last digit, round-off as round-off."""
    assert NUMBER.sub("#", shown) == NUMBER.sub("#", printed), (shown, printed)
    for want, got in zip(NUMBER.findall(shown), NUMBER.findall(printed)):
        if abs(float(want)) < 1e-12:
            assert abs(float(got)) < 1e-12, (want, got)
        else:
            digits = len(want.split("e")[0].replace("-", "").replace(".", "").lstrip("0"))
            assert math.isclose(float(got), float(want), rel_tol=10.0 ** (1 - digits)), (want, got)


def test_every_output_shown_is_printed(tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    namespace, checked = {}, 0
    for code, shown in _blocks():
        printed = io.StringIO()
        with contextlib.redirect_stdout(printed):
            exec(compile(code, "tutorial.md", "exec"), namespace)
        if shown is not None:
            _agree(shown.strip(), printed.getvalue().strip())
            checked += 1
    assert checked == 5


@pytest.mark.parametrize("image", re.findall(r"```\{image\} (\S+)", PAGE))
def test_the_figures_shown_exist(image):
    assert (DOCS / image).stat().st_size > 1000
