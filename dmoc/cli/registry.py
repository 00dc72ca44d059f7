"""The systems the command line knows: the built-ins by name, with their parameters, default
boundary data, control names and how to draw them, and user files given as
``path/to/file.py:factory``, whose factory returns a system or a whole problem.
"""

import contextlib
import importlib.util
import inspect
import pathlib
import sys
import dataclasses
from dataclasses import dataclass

import numpy as np

from ..mechanics import systems
from ..mechanics.system import MechanicalSystem
from ..mechanics.rigid_body import RigidBody
from ..optimal_control.statement.group_problem import GroupOptimalControlProblem
from ..optimal_control.statement.problem import OptimalControlProblem
from .arguments import UsageError


@dataclass(frozen=True)
class SystemSpec:
    """A system for the command line: its factory and what the CLI needs around it.

    Attributes
    ----------
    factory : callable
        Keyword parameters -> MechanicalSystem (the built-ins); a file's factory may
        return an OptimalControlProblem, a RigidBody or a GroupOptimalControlProblem too.
    summary : str
        One line for ``dmoc systems``.
    start, velocity, goal : tuple of float or None
        Default start configuration and velocity (simulate) and goal (optimize); None
        entries of `goal` are free.
    control_names : tuple of str
        Names of the controls (CSV columns, plot legends).
    shape : {"blade", "coin", "point"}
        How `dmoc.animation.animate` draws a system that declares no `bodies`.
    heading, roll : int or None
        Columns of q holding the heading and the rolling angle.
    """

    factory: object
    summary: str
    start: tuple = None
    velocity: tuple = None
    goal: tuple = None
    control_names: tuple = None
    shape: str = "point"
    heading: int = None
    roll: int = None

    def parameters(self):
        """{name: default} of the factory's named parameters."""
        return {name: p.default for name, p in inspect.signature(self.factory).parameters.items()
                if p.kind in (p.POSITIONAL_OR_KEYWORD, p.KEYWORD_ONLY)}

    def control_labels(self, system):
        """`control_names`, or those `system` declares (u0, u1, ... when it declares none)."""
        return self.control_names or system.control_names

    def takes_any_parameter(self):
        """True when the factory takes ``**kwargs``: then any --param name is passed on."""
        return any(p.kind == p.VAR_KEYWORD
                   for p in inspect.signature(self.factory).parameters.values())


BUILT_IN = {
    "knife-edge": SystemSpec(
        systems.knife_edge, "knife edge (Chaplygin sleigh blade) on an inclined plane; "
        "q = (x, y, theta), m = 1 constraint, u = (force along the blade, torque)",
        start=(0.0, 0.0, 0.0), velocity=(1.0, 0.0, 1.0), goal=(0.0, 1.0, 0.0),
        control_names=("force", "torque"), shape="blade", heading=2),
    "rolling-disk": SystemSpec(
        systems.rolling_disk, "vertical disk rolling without slipping; q = (x, y, theta, "
        "phi), theta rolling angle, phi heading, m = 2, u = (rolling torque, steering torque)",
        start=(0.0, 0.0, 0.0, 0.0), velocity=(1.0, 0.0, 1.0, 0.5),
        goal=(1.0, 1.0, None, np.pi / 2), control_names=("roll_torque", "steer_torque"),
        shape="coin", heading=3, roll=2),
    "spherical-pendulum": SystemSpec(
        systems.spherical_pendulum, "spherical pendulum in Cartesian coordinates q = (x, y, z), "
        "z up, holonomic abs(q)^2 = l^2 kept exactly, u = horizontal force (x, y)",
        start=(float(np.sin(1.0)), 0.0, float(-np.cos(1.0))), velocity=(0.0, 1.2, 0.0),
        goal=(0.0, float(np.sin(1.0)), None), control_names=("force_x", "force_y")),
    "lc-circuit": SystemSpec(
        systems.lc_circuit, "LC circuit, two capacitors in parallel (a degenerate Lagrangian); "
        "q = charges (q_L, q_1, q_2), Kirchhoff's current law as the constraint, u = source voltage",
        start=(0.1, 0.05, 0.05), velocity=(0.3, 0.15, 0.15), goal=(1.0, 0.5, 0.5),
        control_names=("voltage",)),
}


def resolve(name):
    """The SystemSpec of a built-in name or of ``path/to/file.py:factory``: the file is
    imported, which runs its top-level code (a script's own code belongs under
    ``if __name__ == "__main__":``), with its folder first on ``sys.path`` while it loads,
    so that it imports a module beside it as ``python path/to/file.py`` would."""
    if name in BUILT_IN:
        return BUILT_IN[name]
    file, sep, attr = name.rpartition(":")
    if not sep or not file.endswith(".py"):
        raise UsageError("SYSTEM", f"must be one of {', '.join(BUILT_IN)} or "
                         f"path/to/file.py:factory; got {name!r}")
    path = pathlib.Path(file)
    if path.is_dir():
        raise UsageError("SYSTEM", f"{file!r} is a folder; expected a Python file defining "
                         f"{attr!r}")
    if not path.is_file():
        raise UsageError("SYSTEM", f"file {file!r} does not exist")
    spec = importlib.util.spec_from_file_location(path.stem, path)
    module = importlib.util.module_from_spec(spec)
    try:
        with _beside(path):
            spec.loader.exec_module(module)
    except SystemExit as done:
        raise UsageError("SYSTEM", f"importing {file} called sys.exit({done.code!r}); expected "
                         f"a file that defines {attr!r} (hint: put a script's own code under "
                         f"`if __name__ == '__main__':`)") from None
    except Exception as err:  # the user's file: say what broke, in one line
        raise UsageError("SYSTEM", f"importing {file} failed: {type(err).__name__}: {err}") from None
    factory = getattr(module, attr, None)
    if not callable(factory):
        raise UsageError("SYSTEM", f"{file} has no callable {attr!r}")
    return SystemSpec(factory, (inspect.getdoc(factory) or attr).splitlines()[0])


@contextlib.contextmanager
def _beside(path):
    """`path`'s folder first on ``sys.path`` while the block runs; the list as it was
    afterwards (the modules imported meanwhile stay in ``sys.modules``)."""
    kept = list(sys.path)
    sys.path.insert(0, str(path.resolve().parent))
    try:
        yield
    finally:
        sys.path[:] = kept


def build(spec, params):
    """Call the factory of `spec` with the ``--param`` values; check that it gives a
    MechanicalSystem or an OptimalControlProblem, or a RigidBody or a
    GroupOptimalControlProblem on SO(3), and return that."""
    known = spec.parameters()
    for key in params:
        if key not in known and not spec.takes_any_parameter():
            raise UsageError("--param", f"{key!r} is not a parameter of this system; its "
                             f"parameters are {', '.join(known) or 'none'}")
    required = [name for name, p in inspect.signature(spec.factory).parameters.items()
                if p.default is inspect.Parameter.empty and name not in params
                and p.kind in (p.POSITIONAL_OR_KEYWORD, p.KEYWORD_ONLY, p.POSITIONAL_ONLY)]
    if required:
        kind = "the class" if inspect.isclass(spec.factory) else "the factory"
        raise UsageError("SYSTEM", f"{kind} {spec.factory.__name__!r} needs {', '.join(required)}, "
                         f"which --param cannot give (numbers only); expected a factory whose "
                         f"parameters all have defaults, e.g. def car(mass=1500.0): return "
                         f"MechanicalSystem(...)")
    return _made(spec, params)


def _made(spec, params):
    """What the factory of `spec` returns for `params`, its errors in one line: a ValueError
    or TypeError blamed on ``--param`` when values were given (the call is shown, so a
    factory's own error is not taken for the values'), on SYSTEM otherwise."""
    try:
        made = spec.factory(**params)
    except (ValueError, TypeError) as err:
        given = ", ".join(f"{k}={v!r}" for k, v in params.items())
        call = f"{getattr(spec.factory, '__name__', 'the factory')}({given})"
        raise UsageError("--param" if params else "SYSTEM",
                         f"{call} raised {type(err).__name__}: {str(err).rstrip('.')}") from None
    except SystemExit as done:
        raise UsageError("SYSTEM", f"the factory called sys.exit({done.code!r}); expected it "
                         f"to return {_RETURNS}") from None
    except Exception as err:  # the user's factory: say what broke, in one line
        raise UsageError("SYSTEM", f"the factory raised {type(err).__name__}: {err}") from None
    if not isinstance(made, (MechanicalSystem, OptimalControlProblem, RigidBody, GroupOptimalControlProblem)):
        raise UsageError("SYSTEM", f"the factory must return {_RETURNS}; got {type(made).__name__}")
    return made


_RETURNS = ("a MechanicalSystem, an OptimalControlProblem, a RigidBody or a "
            "GroupOptimalControlProblem")


def describe():
    """Text of ``dmoc systems``: every built-in with its parameters and defaults."""
    lines = []
    for name, spec in BUILT_IN.items():
        system = spec.factory()
        params = ", ".join(f"{k}={v}" for k, v in spec.parameters().items())
        goal = ",".join("free" if g is None else f"{g:g}" for g in spec.goal)
        lines += [f"{name}", f"  {spec.summary}",
                  f"  coordinates: {', '.join(system.names)}; controls: {', '.join(spec.control_names)}",
                  f"  parameters (--param NAME=VALUE): {params}",
                  f"  defaults: --start {','.join(f'{s:g}' for s in spec.start)} "
                  f"--velocity {','.join(f'{s:g}' for s in spec.velocity)} --goal {goal}", ""]
    lines.append("Your own system or problem: SYSTEM = path/to/file.py:factory, a function "
                 "returning a dmoc.MechanicalSystem or a dmoc.OptimalControlProblem, or a "
                 "dmoc.RigidBody or a dmoc.GroupOptimalControlProblem on SO(3) (its keyword "
                 "arguments become --param names); the file is imported, which runs it.")
    return "\n".join(lines)


def with_heading(spec, heading, names):
    """`spec` with the heading of ``--heading NAME`` (a coordinate of `names`) drawn in the
    path plot and the GIF; `spec` itself when `heading` is None."""
    if heading is None:
        return spec
    if heading not in names:
        raise UsageError("--heading", f"must be one of the coordinates {', '.join(names)} of "
                         f"this system; got {heading!r}")
    return dataclasses.replace(spec, heading=names.index(heading))
