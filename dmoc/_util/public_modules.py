"""The stage modules a user imports by a short name: ``dmoc.systems`` is
`dmoc.mechanics.systems`, the same module object, so ``from dmoc.systems import knife_edge``
and ``dmoc.systems.knife_edge`` name one function."""

import sys


def publish(package, modules):
    """Make each module of `modules` importable as ``<package>.<name>``.

    Parameters
    ----------
    package : str
        The package's name (``"dmoc"``).
    modules : dict of str to module
        Public short name -> the module it names.
    """
    for name, module in modules.items():
        sys.modules[f"{package}.{name}"] = module
