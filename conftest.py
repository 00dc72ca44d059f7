"""Doctests of modules that need an optional extra are skipped, with the reason, when the
extra is not installed (the test extra installs every one of them)."""

import importlib.util

import pytest

# module path -> (module the doctests import, the extra that brings it)
OPTIONAL = {"dmoc/mechanics/robots/robot_system.py": ("adam", "robots")}


def pytest_collection_modifyitems(config, items):
    for path, (module, extra) in OPTIONAL.items():
        if importlib.util.find_spec(module) is not None:
            continue
        skip = pytest.mark.skip(reason=f"the {extra} extra ({module}) is not installed: "
                                       f"pip install -e '.[{extra}]'")
        for item in items:
            if isinstance(item, pytest.DoctestItem) and path in item.nodeid:
                item.add_marker(skip)
