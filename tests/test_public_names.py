"""Every name docs/api.rst documents resolves by attribute (getattr from ``dmoc`` after a bare
``import dmoc``) and by import (`pydoc.locate`, the module part imported), to the same
object (equal, for a bound classmethod); and no function or class sits at the dotted path of
a module (issue 39: the function `dmoc.optimize` once hid the package of that name)."""

import importlib
import json
import pathlib
import pkgutil
import re
import subprocess
import sys

import pytest

import dmoc

API = pathlib.Path(__file__).parents[1] / "docs" / "api.rst"


def documented_names():
    """The dotted names of the autodoc directives of api.rst, with their ``:members:``."""
    names, current = [], None
    lines = API.read_text().splitlines()
    for i, line in enumerate(lines):
        directive = re.match(r"\.\. auto(module|class|function|data|exception):: (\S+)", line)
        if directive:
            current = directive.group(2)
            names.append(current)
            continue
        members = re.match(r"\s+:members: (.*)", line)
        if members and current:
            text = members.group(1)
            for more in lines[i + 1:]:          # continuation lines, indented past the option
                if not more.startswith("      "):
                    break
                text += " " + more.strip()
            names += [f"{current}.{m.strip()}" for m in text.split(",") if m.strip()]
    return names


NAMES = documented_names()

# Run in a fresh interpreter: attribute access first (nothing but ``import dmoc`` done), then
# the import path; a name that resolves only after some other import has run fails here.
RESOLVE = r"""
import functools, json, pydoc, sys
import dmoc
names = json.loads(sys.argv[1])
by_attribute, failures = {}, {}
for name in names:
    try:
        by_attribute[name] = functools.reduce(getattr, name.split(".")[1:], dmoc)
    except AttributeError as err:
        failures[name] = f"by attribute: {err}"
for name in names:
    located = pydoc.locate(name)
    if located is None:
        failures.setdefault(name, "by import: pydoc.locate gives None")
    elif name in by_attribute and located != by_attribute[name]:    # == for bound classmethods
        failures.setdefault(name, f"by import {located!r} is not by attribute {by_attribute[name]!r}")
print(json.dumps(failures))
"""


def test_the_reader_finds_the_documented_names():
    """A test of the test: names of each directive kind and of a :members: list."""
    assert {"dmoc.simulate", "dmoc.optimize", "dmoc.MPC", "dmoc.systems",
            "dmoc.systems.knife_edge", "dmoc.drivers.verdict.judge",
            "dmoc.plotting.save_trajectory_plots"} <= set(NAMES)
    assert len(NAMES) > 100


def test_every_documented_name_resolves_by_attribute_and_by_import():
    out = subprocess.run([sys.executable, "-c", RESOLVE, json.dumps(NAMES)], capture_output=True,
                         text=True, check=True).stdout
    failures = json.loads(out)
    assert not failures, "\n".join(f"{k}: {v}" for k, v in failures.items())


def all_modules():
    """Every module of the package by its dotted name (imports them all)."""
    return ["dmoc"] + [info.name for info in pkgutil.walk_packages(dmoc.__path__, "dmoc.")]


@pytest.mark.parametrize("name", [n for n in all_modules() if n != "dmoc"])
def test_no_object_sits_at_the_path_of_a_module(name):
    """``dmoc.a.b`` by attribute is the module ``dmoc.a.b``, never a function or class
    bound over it in ``dmoc.a``."""
    module = importlib.import_module(name)
    parent, leaf = name.rsplit(".", 1)
    assert getattr(importlib.import_module(parent), leaf) is module


@pytest.mark.parametrize("name", ["systems", "problems", "diagnostics", "plotting", "animation",
                                  "dirac", "formulations", "batch"])
def test_the_short_module_names_are_one_module_each_way(name):
    """``dmoc.systems`` by attribute, by import and by ``from dmoc.systems import ...`` is
    one module object (not a copy under a second name)."""
    module = getattr(dmoc, name)
    assert importlib.import_module(f"dmoc.{name}") is module
    assert module is sys.modules[module.__name__]


def test_the_package_namespace_holds_no_machinery():
    """``dir(dmoc)``: the public names, the stage packages, no sys or importlib."""
    assert not {"sys", "importlib", "publish"} & set(dir(dmoc))
    assert set(dmoc.__all__) <= set(dir(dmoc)) | {"batch"}
