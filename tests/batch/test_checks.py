"""dmoc.batch checks the IPOPT options before anything is submitted (the client address
given here is never reached). Oracle: the messages, checked by content."""

import pytest

import dmoc
from dmoc import batch


@pytest.mark.parametrize("options, words", [
    ({"max_iter": None}, r"`options\['max_iter'\]` must be a number, a string or a bool; got None"),
    ({3: 1}, "string keys .*got the key 3"),
    ({"tol": [1e-8]}, r"`options\['tol'\]`"),
    (["max_iter", 5], "must be a dict of IPOPT options; got list"),
])
def test_batch_checks_ipopt_options(disc, options, words):
    problem = dmoc.OptimalControlProblem(disc, 4, q_start=[0, 0, 0], q_goal=[0, 1, 0])
    with pytest.raises(dmoc.InputTypeError, match=words):
        batch.optimize_many([problem], options=options, client="tcp://127.0.0.1:1")
