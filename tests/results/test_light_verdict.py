"""The light verdict of a re-solve (`dmoc.drivers.verdict.light_judge`, docs/verification.md
"The light verdict of a re-solve"): the simulator's compiled step taken from every knot of
an optimum at once instead of one run from its start, judged at the same REPLAY_TOLERANCE.

Oracles, none taken from the light verdict's code:
- a one-step `dmoc.simulate` from each knot of a sound optimum (the virtual machine's
  stepper, a run of its own from zero increments) lands on the optimum's next knot;
- the full verdict (`judge`) of the same optimum: the same status and the same figures of
  the checks the two share (velocity jumps, path values at the knots);
- an optimum moved at knot 10 by a known amount in q or in p: refused from knot 10 above
  1e-6, passed below.
"""

import time

import numpy as np
import pytest

import dmoc
from dmoc._util import compiled
from dmoc.drivers.verdict import REPLAY_TOLERANCE, judge, light_judge
from dmoc.problems import knife_edge_parking
from tests._helpers import moved_at_knot

pytestmark = pytest.mark.skipif(compiled.compiler() is None, reason="no C compiler")


def light(problem, result, seconds=120.0):
    """`light_judge` of `result` once the compiled step is loaded (in the background)."""
    deadline = time.monotonic() + seconds
    while (verdict := light_judge(problem, result)) is None:
        assert time.monotonic() < deadline, "the compiled step was not loaded"
        time.sleep(0.05)
    return verdict


@pytest.fixture(scope="module")
def parking():
    problem = knife_edge_parking(20)
    return problem, dmoc.optimize(problem)


def test_a_sound_optimum_passes_as_in_the_full_verdict(parking):
    problem, result = parking
    traj = result.trajectory
    verdict, full = light(problem, result), judge(problem, result)
    assert verdict.passed and full.passed
    assert max(verdict.replay_q, verdict.replay_p) < 1e-12 and verdict.replay_step == -1
    shared = ("velocity_jump", "jump_step", "jump_coordinate", "path_violation", "path_step", "path_row")
    assert all(getattr(verdict, name) == getattr(full, name) for name in shared)
    span = np.ptp(traj.q, axis=0).max()
    for k in range(traj.steps):         # each step is the simulator's from the knot before
        step = dmoc.simulate(problem.disc, q0=traj.q[k], p0=traj.p[k], steps=1,
                             controls=traj.u[k:k + 1], jit=False).trajectory
        assert np.abs(step.q[1] - traj.q[k + 1]).max() < 1e-12 * span


@pytest.mark.parametrize("field", ["q", "p"])
@pytest.mark.parametrize("departure, status", [(1e-7, "passed"), (1e-5, "not_replayable")])
def test_an_optimum_moved_at_a_knot_is_refused_from_that_knot(parking, field, departure, status):
    """y at knot 10 moved by `departure` of the span of q, or p_y by `departure` of max |p|:
    the step from knot 9 lands that far from it (and the step from it as far or farther
    from knot 11)."""
    problem, result = parking
    verdict = light(problem, moved_at_knot(result, field, departure))
    figure = {"q": verdict.replay_q, "p": verdict.replay_p}[field]
    assert departure * (1 - 1e-3) <= figure
    assert (figure < REPLAY_TOLERANCE) == (status == "passed")
    assert (verdict.status, verdict.replay_step) == (status, -1 if status == "passed" else 10)


def test_re_solves_of_a_judged_optimum_take_the_light_verdict(parking):
    """The first solve takes the full verdict; a warm re-solve on the compiled NLP from an
    optimum whose verdict passed takes the light one once the compiled step is loaded;
    one from an unjudged optimum, one in the virtual machine (``jit=False``), or of the
    (-) form, the full one."""
    problem, first = parking
    assert first.stats["light_verdict"] is False
    light(problem, first)                       # loaded
    moved = problem.with_boundary(q_goal=[0.0, 1.02, 0.0])
    again = dmoc.optimize(moved, guess=first, jit=True)
    assert again.stats["warm_start"] and again.stats["light_verdict"] and again.verdict.passed
    assert not dmoc.optimize(moved, guess=first, jit=False).stats["light_verdict"]
    unjudged = dmoc.optimize(problem, check=False)
    after = dmoc.optimize(moved, guess=unjudged, jit=True)
    assert after.stats["warm_start"] and not after.stats["light_verdict"]
    minus = knife_edge_parking(20, variant="-")
    judged = dmoc.optimize(minus)
    assert light_judge(minus, judged) is None
    assert not dmoc.optimize(minus.with_boundary(q_goal=[0.0, 1.02, 0.0]), guess=judged,
                             jit=True).stats["light_verdict"]
