"""The bodies and control names a system declares: checked with the rest of its data (a
clear error naming the argument), and those of the built-ins placed where their geometry
says, the oracles written here from the systems' definitions (a blade BLADE long centred
on the contact point, a car body from OVERHANG behind the rear axle to OVERHANG beyond the
front one, the rolling disk's rim mark at -R sin(theta) along the heading)."""

import numpy as np
import pytest

import dmoc
from dmoc.mechanics.bodies import rectangle, segment
from dmoc.mechanics.systems import car, knife_edge
from dmoc.mechanics.systems.car_model import OVERHANG, WIDTH
from dmoc.mechanics.systems.knife_edge_model import BLADE


def free(n, **kwargs):
    return dmoc.MechanicalSystem(lambda q, v: v[0] ** 2 / 2, n, **kwargs)


def test_control_names_default_and_declared():
    assert free(1, n_u=2).control_names == ("u0", "u1")
    assert free(1, n_u=2, control_names=("force", "torque")).control_names == ("force", "torque")
    assert knife_edge().control_names == ("force", "torque")
    assert dmoc.systems.rolling_disk().control_names == ("roll_torque", "steer_torque")


@pytest.mark.parametrize("names, match", [
    (("force",), r"`control_names` must be 2 strings, one for each of the 2 controls"),
    ("force", r"`control_names` must be a sequence of 2 strings"),
    (("f", "f"), r"`control_names` must be distinct .*\['f'\] more than once"),
    (("f,1", "g"), r"`control_names` must not contain commas"),
])
def test_bad_control_names_are_named(names, match):
    with pytest.raises(dmoc.InputError, match=match):
        free(1, n_u=2, control_names=names)


def test_a_body_checks_its_arguments_and_its_outline():
    with pytest.raises(dmoc.InputError, match=r"`name` of a Body must be a non-empty line"):
        dmoc.Body("", lambda q: q[None, :2])
    with pytest.raises(dmoc.InputTypeError, match=r"`outline` of Body 'box' must be a callable"):
        dmoc.Body("box", [[0, 0], [1, 1]])
    with pytest.raises(dmoc.InputTypeError, match=r"`closed` of Body 'box' must be True or False"):
        dmoc.Body("box", lambda q: q[None, :2], closed="yes")
    wrong = dmoc.Body("box", lambda q: q[:2])
    with pytest.raises(dmoc.InputError, match=r"Body 'box' must return points of shape "
                                              r"\(k, 2\), k >= 1; got shape \(2,\)"):
        wrong.points(np.zeros(3))
    broken = dmoc.Body("box", lambda q: q[7])
    with pytest.raises(dmoc.InputError, match=r"Body 'box' .* it raised IndexError"):
        broken.points(np.zeros(3))


def test_a_system_reports_bad_bodies_at_once():
    good = dmoc.Body("a", lambda q: q[None, :2])
    with pytest.raises(dmoc.InputError, match=r"`bodies` must be a list or tuple of dmoc.Body"):
        free(2, bodies=good)
    with pytest.raises(dmoc.InputError, match=r"entries \[1\] are not"):
        free(2, bodies=[good, "b"])
    with pytest.raises(dmoc.InputError) as raised:
        free(2, bodies=[good, good, dmoc.Body("c", lambda q: np.zeros((3, 3)))],
             control_names=("x",))
    message = str(raised.value)
    assert "`bodies` must have distinct names (legend entries); got ['a']" in message
    assert "`bodies[2]`: `outline` of Body 'c' must return points of shape (k, 2)" in message
    assert "`control_names` must be 0 strings" in message       # reported together


def test_the_shape_helpers():
    assert np.allclose(rectangle([1, 2], np.pi / 2, 4, 2), [[2, 0], [2, 4], [0, 4], [0, 0]])
    assert np.allclose(segment([1, 2], 0.0, 2), [[0, 2], [2, 2]])


def test_the_knife_edge_blade_lies_along_the_heading_on_the_contact_point():
    (blade,) = knife_edge().bodies
    q = np.array([1.0, 2.0, np.pi / 2])
    points = blade.points(q)
    assert np.allclose(points[:, 1].min(), 2 - BLADE / 2) and np.allclose(points[:, 1].max(), 2 + BLADE / 2)
    assert np.allclose(points[np.argmax(points[:, 1])], [1.0, 2 + BLADE / 2])   # its tip leads
    assert np.ptp(points[:, 0]) < 0.1 * BLADE                                     # thin


def test_the_car_body_spans_its_axles_and_the_wheel_turns_with_the_steering():
    body, wheel = car(wheelbase=3.0).bodies
    q = np.array([10.0, -1.0, 0.0, 0.4])
    corners = body.points(q)
    assert np.allclose([corners[:, 0].min(), corners[:, 0].max()], [10 - OVERHANG, 13 + OVERHANG])
    assert np.allclose([corners[:, 1].min(), corners[:, 1].max()], [-1 - WIDTH / 2, -1 + WIDTH / 2])
    ends = wheel.points(q)
    assert np.allclose(ends.mean(axis=0), [13.0, -1.0])
    assert np.isclose(np.arctan2(*(ends[1] - ends[0])[::-1]), 0.4)


def test_the_rolling_disk_rim_mark_rolls_along_the_disk():
    disk, mark = dmoc.systems.rolling_disk(radius=0.5).bodies
    q = np.array([1.0, 1.0, np.pi / 2, np.pi / 2])          # heading +y, a quarter turn rolled
    assert np.allclose(mark.points(q), [[1.0, 0.5]])
    assert np.allclose(np.ptp(disk.points(q), axis=0), [0.5 / 4, 1.0])
