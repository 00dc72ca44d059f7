"""Sphinx configuration: myst-parser for the Markdown pages, numpydoc for the API reference,
sphinx-gallery for examples/ (each example runs with small sizes; the PNG and GIF files it
writes are shown under it)."""

import pathlib
import shutil
import sys
import tempfile

ROOT = pathlib.Path(__file__).parents[1]
sys.path.insert(0, str(ROOT))

project = "dmoc"
author = "dmoc developers"
copyright = f"2026, {author}"        # the HTML footer: "© 2026, dmoc developers."
extensions = ["myst_parser", "numpydoc", "sphinx.ext.autodoc", "sphinx.ext.mathjax",
              "sphinx_gallery.gen_gallery"]
source_suffix = {".rst": "restructuredtext", ".md": "markdown"}
exclude_patterns = ["_build"]
html_theme = "alabaster"
myst_heading_anchors = 3
numpydoc_show_class_members = False
numpydoc_validation_checks = set()
autodoc_default_options = {"members": True, "undoc-members": False}
suppress_warnings = ["myst.xref_missing", "config.cache"]

_GALLERY_OUT = pathlib.Path(tempfile.mkdtemp(prefix="dmoc-gallery-"))


def _example_argv(gallery_conf, script_vars):
    """Each example runs with few steps and writes into its own temporary folder."""
    name = pathlib.Path(script_vars["src_file"]).stem
    return ["--steps", "40", "--out", str(_GALLERY_OUT / name)]


def _written_files(block, block_vars, gallery_conf):
    """Scraper: the PNG and GIF files the example wrote, copied into the gallery."""
    folder = _GALLERY_OUT / pathlib.Path(block_vars["src_file"]).stem
    from sphinx_gallery.scrapers import figure_rst

    images = []
    for path in sorted(folder.glob("*.png")) + sorted(folder.glob("*.gif")):
        target = pathlib.Path(next(block_vars["image_path_iterator"])).with_suffix(path.suffix)
        target.unlink(missing_ok=True)
        shutil.copyfile(path, target)   # through the link into the run's set (docs/cli.md)
        path.unlink()
        images.append(str(target))
    return figure_rst(images, gallery_conf["src_dir"])


sphinx_gallery_conf = {
    "examples_dirs": str(ROOT / "examples"),
    "gallery_dirs": "auto_examples",
    "filename_pattern": r"\.py$",
    "reset_argv": _example_argv,
    "image_scrapers": (_written_files,),
    "download_all_examples": False,
    "remove_config_comments": True,
}


def _indent(line):
    return len(line) - len(line.lstrip())


def _plain_text_math(app, what, name, obj, options, lines):
    """dmoc's docstrings write mathematics as plain text (|u|^2, indented displays after a
    colon). Before numpydoc reads them: bars are escaped (no reST substitutions) and a
    display after "...:" becomes a literal block, so it renders as written."""
    for i, line in enumerate(lines):
        if not line.lstrip().startswith(">>>"):
            line = line.replace("|", r"\|")
        after = lines[i + 1:i + 3]
        if (line.rstrip().endswith(":") and not line.rstrip().endswith("::")
                and len(after) == 2 and not after[0].strip() and _indent(after[1]) > _indent(line)):
            line = line.rstrip() + ":"
        lines[i] = line


def setup(app):
    app.connect("autodoc-process-docstring", _plain_text_math, priority=100)
