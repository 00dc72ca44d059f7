"""The diagnostics check what they are given (every size, wrong objects named), handle a
trajectory of zero steps, and the replay error sees every knot.

Oracles, none taken from the code under test: messages by content; a replayed optimum
whose stored momenta or configurations are perturbed by a known amount at one interior
knot."""

import numpy as np
import pytest

import dmoc
from dmoc import diagnostics
from dmoc.dirac import dirac_defect
from dmoc.systems import knife_edge


def test_diagnostics_check_every_size(disc):
    free = dmoc.Trajectory(0.1 * np.arange(3.0), np.zeros((3, 3)), np.zeros((3, 3)), np.zeros((2, 0)),
                           np.zeros((2, 2)), 0.1, "+")
    for check in (diagnostics.residual_norms, diagnostics.constraint_violation, dirac_defect):
        with pytest.raises(ValueError, match=r"`traj.lam`"):
            check(disc, free)


def test_zero_step_trajectory_diagnostics(disc):
    empty = dmoc.Trajectory([0.0], [[0, 0, 0]], [[1, 0, 0]], np.zeros((0, 1)), np.zeros((0, 2)),
                            0.1, "+")
    for check in (diagnostics.energy, diagnostics.residual_norms,
                  diagnostics.constraint_violation, dirac_defect):
        assert check(disc, empty).shape == (0,)


def test_diagnostics_name_wrong_objects(disc, traj):
    with pytest.raises(dmoc.InputTypeError, match="`disc` must be a Discretization; got str"):
        dmoc.dirac.dirac_differential("disc", "+")
    with pytest.raises(dmoc.InputTypeError, match="`problem` must be an OptimalControlProblem"):
        diagnostics.replay_error("problem", None)
    problem = dmoc.OptimalControlProblem(disc, 6, q_start=[0, 0, 0], q_goal=[0, 1, 0])
    with pytest.raises(dmoc.InputTypeError, match="`result.trajectory` must be a Trajectory"):
        diagnostics.replay_error(problem, traj)
    with pytest.raises(dmoc.InputError, match="`tol_rank` must be finite and positive"):
        dmoc.dirac.dirac_defect(disc, traj, tol_rank=-1.0)
    with pytest.raises(dmoc.InputTypeError, match="`disc` must be a Discretization"):
        diagnostics.symplecticity_defect(knife_edge(), [0, 0, 0], [0, 0, 0])


@pytest.fixture(scope="module")
def parking():
    problem = dmoc.OptimalControlProblem(dmoc.discretize(knife_edge(), 0.2), 20,
                                         q_start=[0, 0, 0], q_goal=[0, 1, 0])
    return problem, dmoc.optimize(problem)


@pytest.mark.parametrize("block, knot", [("p", 7), ("p", 13), ("q", 9)])
def test_replay_error_sees_every_knot(parking, block, knot):
    """Mutation: `replay_error` comparing only p_0 (or only q_0) with the replay."""
    problem, result = parking
    assert max(diagnostics.replay_error(problem, result)) < 1e-9
    kicked = dmoc.OptimizationResult(**{**vars(result)})
    traj = result.trajectory
    data = {f: getattr(traj, f) for f in ("t", "q", "p", "lam", "u", "h", "variant", "mu", "s",
                                          "control_nodes")}
    data[block] = data[block].copy()
    data[block][knot, 1] += 1e-3
    kicked.trajectory = dmoc.Trajectory(**data)
    errors = dict(zip("qp", diagnostics.replay_error(problem, kicked)))
    assert errors[block] == pytest.approx(1e-3, rel=1e-6)
