"""The light verdict's figures in one compiled evaluation (`dmoc.drivers.verdict_figures`,
docs/verification.md "The light verdict of a re-solve"): the Verdict of `light_judge`
equal, field by field, to the one the NumPy path makes while the compiled Function is not
loaded, and to the full verdict's wherever the two measure the same thing.

Oracles, none taken from the compiled Function:
- the NumPy path of `light_judge` (`step_replay.step_departure`, the interpolants' end
  velocities, `knot_path_values_of`, `interpolant_path_values`, `verdict_checks`);
- the full verdict (`judge`: a `dmoc.simulate` run from the optimum's start): its status
  and every figure but the replay's, which measures one run, not a step from each knot;
- optima of each status: an under-resolved parking on 10 steps, the same optimum moved at
  knot 5 by 1e-5 of its span (not replayable from knot 5), a heading-rate limit and
  velocity bounds that an unconstrained optimum crosses at its knots and between them
  (path violated), the rolling disk on lobatto4 steps and the constrained parking's own
  optimum (passed).
"""

import dataclasses
import time

import casadi as ca
import pytest

import dmoc
from dmoc._util import compiled
from dmoc.drivers import verdict
from dmoc.drivers.step_replay import replay_stepper
from dmoc.drivers.verdict_figures import figures
from dmoc.problems import knife_edge_parking, rolling_disk_steering
from tests._helpers import moved_at_knot

pytestmark = pytest.mark.skipif(compiled.compiler() is None, reason="no C compiler")


def rate_limited(**constraints):
    """Knife-edge parking on 12 lobatto3 steps under a heading-rate limit of 0.6 and bounds
    on the knot velocities of x and theta (`constraints` replaces them)."""
    disc = dmoc.discretize(dmoc.systems.knife_edge(), 4.0 / 12, "lobatto3")
    given = dict(path_constraints=lambda q, v, u: ca.vertcat(v[2] - 0.6, -v[2] - 0.6),
                 velocity_bounds=([-0.6, None, -1.0], [0.6, None, None]))
    return dmoc.OptimalControlProblem(disc, 12, q_start=[0, 0, 0], q_goal=[0, 1, 0],
                                      **{**given, **constraints})


def cases():
    """{name: (problem, optimum)} of each status (the module notes)."""
    parking = knife_edge_parking(10)
    coarse = dmoc.optimize(parking, check=False)
    limited = rate_limited()
    free = dmoc.optimize(rate_limited(path_constraints=None, velocity_bounds=None), check=False)
    disk = rolling_disk_steering(6, rule="lobatto4")
    return {"under_resolved": (parking, coarse),
            "not_replayable": (parking, moved_at_knot(coarse, "q", 1e-5, knot=5)),
            "path_violated": (limited, free),
            "passed": (limited, dmoc.optimize(limited, check=False)),
            "passed on lobatto4": (disk, dmoc.optimize(disk, check=False))}


@pytest.fixture(scope="module")
def judged():
    """{name: (compiled Verdict, NumPy path's Verdict, full Verdict, problem, optimum)}."""
    found = {}
    for name, (problem, result) in cases().items():
        traj = result.trajectory
        deadline = time.monotonic() + 120.0
        assert replay_stepper(problem, traj).loading.wait(120.0)
        while figures(problem, traj, replay_stepper(problem, traj)) is None:
            assert time.monotonic() < deadline, "the compiled figures were not loaded"
            time.sleep(0.05)
        light = verdict.light_judge(problem, result)
        saved, verdict.figures = verdict.figures, lambda *args: None
        try:
            numpy_path = verdict.light_judge(problem, result)
        finally:
            verdict.figures = saved
        found[name] = (light, numpy_path, verdict.judge(problem, result), problem, result)
    return found


@pytest.mark.parametrize("name", ["under_resolved", "not_replayable", "path_violated", "passed",
                                  "passed on lobatto4"])
def test_the_compiled_figures_make_the_numpy_paths_verdict(judged, name):
    light, numpy_path, full, _, _ = judged[name]
    assert dataclasses.asdict(light) == dataclasses.asdict(numpy_path)
    assert light.status == full.status == name.split()[0]
    replay = {"replay_q", "replay_p", "replay_step"}
    assert all(getattr(light, f.name) == getattr(full, f.name)
               for f in dataclasses.fields(light) if f.name not in replay)


def test_a_re_solve_takes_the_compiled_figures_once_loaded(judged):
    """`dmoc.optimize`'s warm re-solve of the rate-limited parking from its judged optimum,
    on the compiled NLP: the light verdict, from the compiled figures (loaded by the
    fixture), equal to `light_judge`'s NumPy path on the re-solve's optimum."""
    problem = judged["passed"][3]
    moved = problem.with_boundary(q_goal=[0.0, 1.02, 0.0])
    again = dmoc.optimize(moved, guess=dmoc.optimize(problem, jit=True), jit=True)
    assert again.stats["light_verdict"] and again.stats["verdict_compiled"] and again.verdict.passed
    saved, verdict.figures = verdict.figures, lambda *args: None
    try:
        assert verdict.light_judge(moved, again) == again.verdict
    finally:
        verdict.figures = saved


def test_each_check_is_exercised(judged):
    """The figures the cases must reach for the comparison to mean something: a departure
    first at knot 5, a jump above 1, a violated velocity bound and path row at the knots
    and a path row cut between them, figures at round-off where an optimum passes."""
    moved, coarse, violated = (judged[name][0] for name in ("not_replayable", "under_resolved", "path_violated"))
    assert moved.replay_step == 5 and 1e-5 * (1 - 1e-3) <= moved.replay_q < 1e-4
    assert coarse.velocity_jump > 1 and coarse.replay_step == -1
    assert violated.path_violation > 1e-3 and violated.path_cut > 0 and violated.path_cut_step >= 0
    assert violated.path_limit.startswith(("velocity_bounds", "path_constraints"))
    for name in ("passed", "passed on lobatto4"):
        light = judged[name][0]
        assert max(light.replay_q, light.replay_p) < 1e-10 and light.path_violation < 1e-6
