"""Fixtures of the results tests."""

import numpy as np
import pytest

import dmoc


@pytest.fixture(scope="module")
def traj(disc):
    """Six knife-edge steps under random controls: a trajectory with every field filled."""
    return dmoc.simulate(disc, q0=[0, 0, 0.3], v0=[np.cos(0.3), np.sin(0.3), 1.0], steps=6,
                         controls=np.random.default_rng(1).normal(size=(6, 2))).trajectory
