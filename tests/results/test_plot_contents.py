"""What the plots show, read back from their matplotlib objects: one panel per control,
labels with the system's units, bound lines, obstacles, a goal with a free entry, the paths
of several bodies, no clipped label, GIFs of the motion's aspect; and the energy balance.

Oracles, none taken from the code under test: the units, bounds, obstacles and goals
written in this file; the energy balance of the midpoint rule on the LC circuit (quadratic
L, constant constraint one-form), an identity derived in docs/stages/results.md:
E_k - E_{k-1} = (impulse at knot k) . (v_{k-1} + v_k)/2 exactly, so E - E_0 - W vanishes to
round-off; and for the knife edge (whose one-form turns) the order at which the balance
vanishes as h -> 0 (slope within 0.35 over three step sizes): 2 for the midpoint rule, 4
for Lobatto3 (stage impulses at its middle node).
"""

import casadi as ca
import numpy as np
import pytest
from PIL import Image

import dmoc
from dmoc import plotting
from dmoc.results._canvas import plane_limits
from dmoc.results.diagnostic_plots import control_work
from dmoc.systems import knife_edge, lc_circuit, point_vortices

KNIFE_UNITS = {"t": "s", "q": ("m", "m", "rad"), "u": ("N", "N m")}


@pytest.fixture(scope="module")
def bounded():
    """Knife-edge parking with the force bounded by 1.2 N and y by [-0.1, 1.1] m."""
    disc = dmoc.discretize(knife_edge(), 4.0 / 30)
    problem = dmoc.OptimalControlProblem(
        disc, 30, q_start=[0, 0, 0], q_goal=[0, 1, 0], control_bounds=([-1.2, None], [1.2, None]),
        state_bounds=([None, -0.1, None], [None, 1.1, None]))
    return problem, dmoc.optimize(problem).trajectory


def test_one_panel_per_control_labelled_with_its_unit(bounded):
    _, traj = bounded
    fig = plotting.plot_controls(traj, names=["force", "torque"], units=KNIFE_UNITS)
    assert [ax.get_ylabel() for ax in fig.axes] == ["force [N]", "torque [N m]"]
    assert [ax.get_xlabel() for ax in fig.axes] == ["", "t [s]"]
    fig = plotting.plot_states(traj, names=["x", "y", "theta"], units=KNIFE_UNITS)
    assert [ax.get_ylabel() for ax in fig.axes] == ["x [m]", "y [m]", "theta [rad]"]


def test_built_in_systems_declare_their_units():
    assert knife_edge().units == KNIFE_UNITS
    assert lc_circuit().units == {"t": "s", "q": ("C", "C", "C"), "u": ("V",)}
    assert dmoc.systems.rolling_disk().units["u"] == ("N m", "N m")
    assert dmoc.MechanicalSystem(lambda q, v: v[0] ** 2, 1).units == {"t": "", "q": ("",), "u": ()}


def horizontal_lines(ax):
    return sorted(line.get_ydata()[0] for line in ax.lines
                  if len(set(line.get_ydata())) == 1 and line.get_linestyle() == "--")


def test_bound_lines_are_drawn_where_bounds_are_finite(bounded):
    problem, traj = bounded
    fig = plotting.plot_controls(traj, bounds=problem.control_bounds)
    assert horizontal_lines(fig.axes[0]) == [-1.2, 1.2]
    assert horizontal_lines(fig.axes[1]) == []
    assert fig.axes[0].get_legend_handles_labels()[1] == ["bound"]
    fig = plotting.plot_states(traj, bounds=problem.state_bounds)
    assert [horizontal_lines(ax) for ax in fig.axes] == [[], [-0.1, 1.1], []]


def test_obstacle_discs_and_regions_are_drawn(bounded):
    _, traj = bounded
    ax = plotting.plot_path(traj, obstacles=[[0.3, 0.5, 0.1], [-0.3, 0.5, 0.05]]).axes[0]
    circles = [p for p in ax.patches if type(p).__name__ == "Circle"]
    assert [(c.center, c.radius) for c in circles] == [((0.3, 0.5), 0.1), ((-0.3, 0.5), 0.05)]
    ax = plotting.plot_path(traj, obstacles=lambda x, y: 0.01 - (x - 0.3) ** 2 - (y - 0.5) ** 2).axes[0]
    contours = [c for c in ax.collections if type(c).__name__ in ("QuadContourSet", "PathCollection")]
    assert contours, ax.collections
    assert "kept out" in [t.get_text() for legend in ax.artists for t in legend.get_texts()]


def test_a_goal_with_a_free_entry_is_a_line(bounded):
    _, traj = bounded
    ax = plotting.plot_path(traj, goal=[0.0, np.nan, 0.0]).axes[0]
    (line,) = [l for l in ax.lines if l.get_label() == "goal (y free)"]
    assert list(line.get_xdata()) == [0.0, 0.0]
    ax = plotting.plot_path(traj, goal=[np.nan, 1.0, 0.0]).axes[0]
    assert [list(l.get_ydata()) for l in ax.lines if l.get_label() == "goal (x free)"] == [[1.0, 1.0]]


def test_planes_are_found_by_name():
    assert plotting.planes(("x", "y", "theta")) == [(0, 1)]
    assert plotting.planes(("x_1", "y_1", "x_2", "y_2")) == [(0, 1), (2, 3)]
    assert plotting.planes(("q_L", "q_1", "q_2")) == []
    assert plotting.planes(("q0", "q1")) == [(0, 1)]


def test_non_planar_and_many_body_defaults(tmp_path):
    disc = dmoc.discretize(lc_circuit(), 0.1)
    traj = dmoc.simulate(disc, q0=[0.1, 0.05, 0.05], v0=[0.3, 0.15, 0.15], steps=10).trajectory
    written = plotting.save_trajectory_plots(traj, tmp_path, "lc", disc=disc)
    assert [p.name for p in written] == ["lc_states.png", "lc_controls.png", "lc_constraint.png",
                                         "lc_energy.png"]      # no path: no plane
    disc = dmoc.discretize(point_vortices([1.0, 2.0]), 0.1)
    traj = dmoc.simulate(disc, q0=[1, 0, -0.5, 0.3], v0=np.zeros(4), steps=10).trajectory
    figures = plotting._figures(traj, "pair", disc, None, disc.system.names, None,
                                disc.system.units, None, None, None)
    ax = figures["path"].axes[0]
    paths = [l for l in ax.lines if l.get_label().startswith("x_")]
    assert [l.get_label() for l in paths] == ["x_1, y_1", "x_2, y_2"]
    assert paths[0].get_color() != paths[1].get_color()
    names = ax.get_legend().get_texts()
    assert len({t.get_text() for t in names}) == len(names)        # no entry twice


def test_no_label_is_clipped(bounded, tmp_path):
    problem, traj = bounded
    figures = plotting._figures(traj, "park", problem.disc, problem, ("x", "y", "theta"),
                                ("force along the blade", "torque"), KNIFE_UNITS, 2, None, None)
    for kind, fig in figures.items():
        renderer = fig.canvas.get_renderer()
        for ax in fig.axes:         # the drawn tick labels, axis labels and title of each
            drawn = ax.get_tightbbox(renderer)
            assert drawn.x0 >= -0.5 and drawn.y0 >= -0.5, (kind, drawn)
            assert drawn.x1 <= fig.bbox.x1 + 0.5 and drawn.y1 <= fig.bbox.y1 + 0.5, (kind, drawn)


def test_energy_balance_of_the_lc_circuit_optimum_is_an_identity():
    disc = dmoc.discretize(lc_circuit(0.8, (0.5, 1.5)), 3.0 / 30)
    problem = dmoc.OptimalControlProblem(disc, 30, q_start=[0, 0, 0], q_goal=[1, 0.25, 0.75])
    traj = dmoc.optimize(problem).trajectory
    E = dmoc.diagnostics.energy(disc, traj)
    change = np.abs(E - E[0]).max()
    assert change > 0.1                                   # the controls do work
    assert np.abs(E - E[0] - control_work(disc, traj)).max() < 1e-13 * max(1.0, change)
    fig = plotting.plot_energy_balance(disc, traj, time_unit="s")
    balance = [l for l in fig.axes[0].lines if l.get_label().startswith("balance")][0]
    assert np.abs(balance.get_ydata()).max() < 1e-13
    assert fig.axes[0].get_xlabel() == "t [s]"


@pytest.mark.parametrize("rule, order", [("midpoint", 2), ("lobatto3", 4)])
def test_energy_balance_of_the_knife_edge_vanishes_at_the_measured_order(rule, order):
    balances = []
    for N in (20, 40, 80):
        disc = dmoc.discretize(knife_edge(), 4.0 / N, rule=rule)
        problem = dmoc.OptimalControlProblem(disc, N, q_start=[0, 0, 0], q_goal=[0, 1, 0])
        traj = dmoc.optimize(problem).trajectory
        E = dmoc.diagnostics.energy(disc, traj)
        balances.append(np.abs(E - E[0] - control_work(disc, traj)).max())
    slope = np.polyfit(np.log([4 / 20, 4 / 40, 4 / 80]), np.log(balances), 1)[0]
    assert abs(slope - order) < 0.35, (balances, slope)


def test_the_saved_energy_plot_of_an_optimum_is_its_balance(bounded, tmp_path):
    problem, traj = bounded
    plotting.save_trajectory_plots(traj, tmp_path, "park", problem=problem)
    figures = plotting._figures(traj, "park", problem.disc, problem, ("x", "y", "theta"), None,
                                KNIFE_UNITS, None, None, None)
    ax = figures["energy"].axes[0]
    assert "energy balance" in ax.get_title() and ax.get_ylabel() == "energy"
    assert horizontal_lines(figures["controls"].axes[0]) == [-1.2, 1.2]


def test_gif_has_the_motion_aspect_and_units(tmp_path):
    disc = dmoc.discretize(knife_edge(), 0.1)
    wide = dmoc.simulate(disc, q0=[0, 0, 0], v0=[1, 0, 0], steps=40).trajectory   # along x
    path = dmoc.animation.animate(wide, tmp_path / "wide.gif", shape="blade", heading=2,
                                  units=KNIFE_UNITS, frames=5)
    with Image.open(path) as gif:
        assert gif.n_frames == 5 and gif.size[0] > 1.5 * gif.size[1]


def test_bad_units_are_named():
    with pytest.raises(dmoc.InputError, match=r"`units\['q'\]` must be 3 one-line strings"):
        dmoc.MechanicalSystem(lambda q, v: v[0] ** 2, 3, units={"q": ("m",)})
    with pytest.raises(dmoc.InputError, match=r"`units` has unknown keys \['x'\]"):
        dmoc.MechanicalSystem(lambda q, v: v[0] ** 2, 1, units={"x": "m"})
    with pytest.raises(dmoc.InputError, match=r"`units` must be a mapping"):
        dmoc.HamiltonianSystem(lambda q, p: p[0] ** 2, 1, units=["m"])
    traj = dmoc.simulate(dmoc.discretize(knife_edge(), 0.1), q0=[0, 0, 0], v0=[1, 0, 1],
                         steps=3).trajectory
    with pytest.raises(dmoc.InputError, match=r"`units` is invalid for this trajectory"):
        plotting.plot_states(traj, units={"q": ("m", "m")})


@pytest.mark.parametrize("line_break", ["\n", "\r"])
@pytest.mark.parametrize("key", ["t", "q", "u"])
def test_a_unit_with_a_line_break_is_refused(key, line_break):
    """A unit is one line of text: a line break would split an axis label, a CSV header
    or the animation's clock. Each key, each of the two breaks, named in the error."""
    unit = "m" + line_break + "s"
    units = {"t": unit, "q": ("m", unit), "u": (unit,)}[key]
    def make(units):
        return dmoc.MechanicalSystem(lambda q, v: (v[0] ** 2 + v[1] ** 2) / 2, 2, n_u=1,
                                     force=lambda q, v, u: ca.vertcat(u[0], 0), units=units)
    assert make({"t": "s", "q": ("m", "m s"), "u": ("N",)}).units["q"] == ("m", "m s")
    with pytest.raises(dmoc.InputError, match=rf"is invalid:\n  - `units\['{key}'\]` must be "
                                              rf"[^\n]*one.line[^\n]*$"):
        make({key: units})


def test_bad_obstacles_and_bounds_are_named(bounded):
    _, traj = bounded
    with pytest.raises(dmoc.InputError, match=r"`obstacles` must be discs .* got shape \(2,\)"):
        plotting.plot_path(traj, obstacles=[1.0, 2.0])
    with pytest.raises(dmoc.InputError, match=r"`obstacles` must have radii > 0"):
        plotting.plot_path(traj, obstacles=[[0, 0, -1.0]])
    with pytest.raises(dmoc.InputError, match=r"`obstacles` as a callable .* raised ZeroDivisionError"):
        plotting.plot_path(traj, obstacles=lambda x, y: 1 / 0)
    with pytest.raises(dmoc.InputError, match=r"`bounds` must be a pair \(lower, upper\) of "
                                              r"arrays of shape \(2,\); got shapes"):
        plotting.plot_controls(traj, bounds=([0, 0, 0], [1, 1, 1]))


@pytest.mark.parametrize("extent", [(0.05, 3.0), (3.0, 0.05), (1.0, 1.0)])
def test_gif_labels_are_not_clipped(extent):
    from dmoc.results import animation

    xs, ys = np.linspace(0, extent[0], 5) - 1000.0, np.linspace(0, extent[1], 5) * -1e4
    xlim, ylim, to_scale = plane_limits(np.column_stack([xs, ys]))
    fig, ax = animation._canvas(animation._widened((xlim, ylim)) if to_scale else (xlim, ylim),
                                to_scale)
    animation._frame_axes(ax, None, ["x [m]", "y [m]"], "a title")
    animation._fit(fig, ax)
    drawn = ax.get_tightbbox(fig.canvas.get_renderer())
    assert drawn.x0 >= -0.5 and drawn.y0 >= -0.5 and drawn.y1 <= fig.bbox.y1 + 0.5
    assert drawn.x1 <= fig.bbox.x1 + 0.5
