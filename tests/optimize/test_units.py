"""The NLP scaling and the default guess follow the units: a problem stated in metres,
millimetres or kilometres, kilograms or grams is solved in the same iterations to the
same optimum (`dmoc.optimal_control.nlp.scaling.lengths`).

Oracles, none taken from the code under test:
- the same problem in SI, its optimum converted to the other units by hand (x, y and the
  force by the length unit, the torque by its square, the masses by the mass unit);
- the lengths of the knife edge's coordinates in closed form: d = sqrt(m) |dy| for a
  motion dy along y, l = (d / sqrt(m), d / sqrt(m), min(d / sqrt(J), 1)), the heading's
  1 rad being where its constraint row (-sin theta, cos theta, 0) turns by its own size;
- the default guess written out: the chord bent by 0.1 l_i sin(pi t / T).
"""

import casadi as ca
import numpy as np
import pytest

import dmoc
from dmoc.optimal_control import initial_guess
from dmoc.optimal_control.nlp.scaling import lengths
from dmoc.systems import car, knife_edge

STEPS, T = 100, 4.0
METRE = {"m": 1.0, "mm": 1e-3, "km": 1e3}       # the unit of length, in metres
KILOGRAM = {"kg": 1.0, "g": 1e-3}               # the unit of mass, in kilograms


def parking(length="m", mass="kg", *, system=knife_edge, goal=(0.0, 1.0, 0.0), **inertias):
    """Knife-edge parking (0, 0, 0) -> `goal` (SI) in 4 s, m = J = 1 in SI, stated in the
    units `length` and `mass`, with the cost (F / 1 N)^2 + (tau / 1 N m)^2 in those units."""
    L, M = METRE[length], KILOGRAM[mass]
    m, J = inertias.get("mass", 1.0) / M, inertias.get("inertia", 1.0) / (M * L * L)
    newton = M * L                              # 1 N in the units' force: kg m / s^2 -> M L
    disc = dmoc.discretize(system(mass=m, inertia=J), T / STEPS)
    return dmoc.OptimalControlProblem(
        disc, STEPS, q_start=[0.0, 0.0, 0.0], q_goal=np.array(goal) / [L, L, 1.0],
        running_cost=lambda q, v, u: (u[0] * newton) ** 2 + (u[1] * newton * L) ** 2)


@pytest.fixture(scope="module")
def si():
    return dmoc.optimize(parking())


@pytest.mark.parametrize("length, mass", [("mm", "kg"), ("km", "kg"), ("m", "g"), ("mm", "g"),
                                          ("km", "g")])
def test_parking_in_other_units_takes_the_iterations_and_has_the_optimum_of_si(si, length, mass):
    """Before: 1000 iterations (Maximum_Iterations_Exceeded) in millimetres, 14 in
    kilometres, 10 in metres. Now the same iterations to 1, the cost to 1e-8 and the
    configurations and controls, converted to SI, to 1e-7 of their size."""
    L, M = METRE[length], KILOGRAM[mass]
    result = dmoc.optimize(parking(length, mass))
    assert abs(result.stats["iterations"] - si.stats["iterations"]) <= 1
    assert result.cost == pytest.approx(si.cost, rel=1e-8)
    q, u = result.trajectory.q * [L, L, 1.0], result.trajectory.u * [M * L, M * L * L]
    np.testing.assert_allclose(q, si.trajectory.q, rtol=0, atol=1e-7 * np.abs(si.trajectory.q).max())
    np.testing.assert_allclose(u, si.trajectory.u, rtol=0, atol=1e-7 * np.abs(si.trajectory.u).max())


def scaled_values(problem, z):
    """(f, g) of the scaled NLP that IPOPT sees, at the scaled point z."""
    F = ca.Function("fg", [problem.nlp["x"], problem.nlp["p"]], [problem.nlp["f"], problem.nlp["g"]])
    f, g = F(z, problem.p)
    return float(f), np.array(g).ravel()


@pytest.mark.parametrize("length, mass", [(2.0 ** -10, 1.0), (2.0 ** 10, 2.0 ** -10)])
def test_units_apart_by_powers_of_two_give_the_same_scaled_nlp(length, mass):
    """The car (1500 kg, wheelbase 2.7 m) to (20, 2) in 10 s, in SI and in units of
    `length` metres and `mass` kilograms (the scale factors are then exact): at a random
    scaled point the objective and the rows agree to rounding, and IPOPT takes the same
    iterations to the same optimum."""
    def lane_change(L, M):
        system = car(mass=1500.0 / M, yaw_inertia=2500.0 / (M * L * L),
                     steering_inertia=1.0 / (M * L * L), wheelbase=2.7 / L)
        disc = dmoc.discretize(system, 0.1)
        return dmoc.OptimalControlProblem(
            disc, 100, q_start=[0, 0, 0, 0], q_goal=[20.0 / L, 2.0 / L, 0, 0],
            running_cost=lambda q, v, u: (u[0] * M * L) ** 2 + (u[1] * M * L * L) ** 2)
    a, b = lane_change(1.0, 1.0), lane_change(length, mass)
    z = np.random.default_rng(5).uniform(-1, 1, a.x_layout.size)
    (fa, ga), (fb, gb) = scaled_values(a, z), scaled_values(b, z)
    assert fb == pytest.approx(fa, rel=1e-14)
    assert np.abs(ga - gb).max() <= 1e-14 * np.abs(ga).max()
    ra, rb = dmoc.optimize(a), dmoc.optimize(b)
    assert ra.stats["iterations"] == rb.stats["iterations"]
    assert rb.cost == pytest.approx(ra.cost, rel=1e-12)


@pytest.mark.parametrize("mass, inertia, dy", [(1.0, 1.0, 1.0), (1e3, 1.0, 1.0), (1.0, 1e-3, 2.5),
                                               (4.0, 100.0, 1.0)])
def test_lengths_of_the_knife_edge_coordinates(mass, inertia, dy):
    system = knife_edge(mass=mass, inertia=inertia)
    d = np.sqrt(mass) * dy
    expected = [d / np.sqrt(mass), d / np.sqrt(mass), min(d / np.sqrt(inertia), 1.0)]
    np.testing.assert_allclose(lengths(system, np.array([0.0, 0.0, 0.3]), np.array([0.0, dy, 0.0])),
                               expected, rtol=1e-14)


@pytest.mark.parametrize("length", ["m", "mm", "km"])
def test_default_guess_bends_each_coordinate_in_its_own_units(length):
    """The chord from 0 to (0, 1 m, 0) bent by 0.1 l_i sin(pi t / T), l = (1 m, 1 m,
    1 rad) in the units: the heading bulges by 0.1 rad in every unit (before: 100 rad in
    millimetres, the bump being 0.1 max(1, |goal - start|) on every coordinate)."""
    L = METRE[length]
    problem = parking(length)
    q = problem.configurations(initial_guess(problem))
    bump = 0.1 * np.sin(np.pi * np.linspace(0.0, 1.0, STEPS + 1))
    expected = np.column_stack([bump / L, (np.linspace(0.0, 1.0, STEPS + 1) + bump) / L, bump])
    np.testing.assert_allclose(q, expected, rtol=1e-13, atol=1e-13 / L)
