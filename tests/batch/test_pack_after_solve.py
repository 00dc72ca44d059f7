"""A problem solved in this process ships to batch workers (issue 41): its momenta keep
their mapped Function as an `Evaluator` (thread-local buffers) once a result's trajectory
was read, and the packed problem must still pickle and solve alike.

Oracle: the same problem solved in this process before packing (the same x bit for bit,
the NLP being the same Functions)."""

import numpy as np

import dmoc
from dmoc.batch.tasks import pack_problem, unpack_problem
from dmoc.problems import knife_edge_parking


def test_a_problem_whose_momenta_were_evaluated_packs_and_solves_alike():
    problem = knife_edge_parking(10, rule="lobatto3")
    here = dmoc.optimize(problem)
    assert here.trajectory.p.shape == (11, 3)        # the momenta evaluated, their Function kept
    there = dmoc.optimize(unpack_problem(pack_problem(problem)))
    assert there.verdict.passed
    assert there.x.tobytes() == here.x.tobytes()
    np.testing.assert_array_equal(there.trajectory.p, here.trajectory.p)
