"""Helpers shared by test modules of several stages (fixtures live in conftest.py)."""

from dataclasses import fields, replace

import casadi as ca

import numpy as np

import dmoc

# Valid knife-edge data for simulate(): the tests replace one argument at a time.
GOOD = dict(q0=[0.0, 0.0, 0.3], v0=[np.cos(0.3), np.sin(0.3), 1.0], steps=5)


def same(a, b):
    """True if the dataclasses `a` and `b` (trajectories) hold bit-identical fields."""
    return all(np.array_equal(getattr(a, f.name), getattr(b, f.name)) for f in fields(a))


def problem(disc, **kwargs):
    """A 10-step problem on `disc` from the origin to (0, 0.1, 0), with `kwargs` added."""
    return dmoc.OptimalControlProblem(disc, 10, q_start=[0, 0, 0], q_goal=[0, 0.1, 0], **kwargs)


def moved_at_knot(result, field, departure, knot=10):
    """`result` with its trajectory's y at `knot` moved by `departure` of the span of q
    (`field` "q"), or p_y by `departure` of max |p| ("p"): an optimum that departs from the
    step equations there by that much."""
    traj = result.trajectory
    q, p = traj.q.copy(), traj.p.copy()
    if field == "q":
        q[knot, 1] += departure * np.ptp(traj.q, axis=0).max()
    else:
        p[knot, 1] += departure * np.abs(traj.p).max()
    moved = dmoc.Trajectory(traj.t, q, p, traj.lam, traj.u, traj.h, traj.variant)
    return replace(result, trajectory=moved)


def lagrangian_gradient(transcription):
    """Function ``(x, p, lam_g) -> grad f + J^T lam_g`` of the scaled NLP of `transcription`,
    from CasADi's dense Jacobian of the NLP's expressions (not the Functions IPOPT or
    dmoc's KKT matrix evaluate): the stationarity an optimum's multipliers must give."""
    x, p = transcription.nlp["x"], transcription.nlp["p"]
    lam = type(x).sym("lam", transcription.g_layout.size)
    return ca.Function("lagrangian_gradient", [x, p, lam], [
        ca.gradient(transcription.nlp["f"], x) + ca.mtimes(ca.jacobian(transcription.nlp["g"], x).T, lam)])
