"""
A lane change past a parked car, stated in a problem file
=========================================================

A car (`dmoc.systems.car`, a kinematic bicycle with the steering angle as a coordinate, in
SI units) drives at 10 m/s in the right lane and must change to the left lane, 3.5 m over,
and end there straight with the steering centred, while passing a parked car (a disc of
radius 2 m at x = 9 m, our car's half width included) that blocks its lane; how far it
drives is free. The optimum swerves just clear of the parked car with the steering
torque at its bound, and takes about 1.6 s. The drive force and the steering torque are bounded, and so are the
steering angle and the lateral position (the two lanes); the final time is free in
[0.5, 8] s, and the cost is the control effort plus a price on time,
``int (F/F_ref)^2 + (tau/tau_ref)^2 + TIME_PRICE dt``.

The function `lane_change` returns the whole `dmoc.OptimalControlProblem`, so the command
line solves it as it is stated here, and replays its optimum with the simulator::

    dmoc optimize examples/lane_change_problem.py:lane_change --heading theta --out out
    dmoc simulate examples/lane_change_problem.py:lane_change --controls out/lane_change.csv

The replay takes the step h and the start (q_0, p_0) from the table the optimization
wrote. The plots and the GIF (``--animate``) draw the car's body and front wheel, which
`dmoc.systems.car` declares (`dmoc.Body`), and the parked car that the path constraints
keep out (its disc includes our car's half width, which the drawn body shows crossing it:
the constraints hold the axles' midpoints outside). Run as a script, this file does both through `dmoc.cli.main`::

    python examples/lane_change_problem.py [--steps 60] [--out dmoc-output]
"""

# The gallery's thumbnail is the path with the car drawn at a few poses (the figures are
# shown in file-name order: constraint, controls, energy, path, states, then the GIF).
# sphinx_gallery_thumbnail_number = 4

import casadi as ca

import dmoc
from dmoc.cli import example_arguments, main as dmoc_command

SPEED = 10.0                        # m/s, at the start
LANE = 3.5                          # m, the lane width: the goal's y
OBSTACLE, RADIUS = (9.0, 0.0), 2.0  # m: the parked car, with the margin of our car's width
FORCE, TORQUE = 4000.0, 10.0        # N, N m: the control bounds (braking up to 2 FORCE)
STEERING = 0.3                      # rad: the bound of the steering angle
EFFORT_SCALE = (4000.0, 50.0)       # N, N m: F_ref and tau_ref of the cost
TIME_PRICE = 0.01                   # cost per second


def lane_change(steps=60, wheelbase=2.7):
    """The lane change past a parked car, as an OptimalControlProblem of `steps` steps."""
    car = dmoc.systems.car(wheelbase=wheelbase)

    def effort_and_time(q, v, u):
        return (u[0] / EFFORT_SCALE[0]) ** 2 + (u[1] / EFFORT_SCALE[1]) ** 2 + TIME_PRICE

    def clear_of_the_parked_car(q, v, u):
        rear = q[:2]
        front = rear + wheelbase * ca.vertcat(ca.cos(q[2]), ca.sin(q[2]))
        return ca.vertcat(*(RADIUS ** 2 - ca.sumsqr(point - ca.DM(OBSTACLE))
                            for point in (rear, front)))

    guess_duration = 2.0
    return dmoc.OptimalControlProblem(
        dmoc.discretize(car, guess_duration / steps), steps,
        q_start=[0.0, 0.0, 0.0, 0.0], v_start=[SPEED, 0.0, 0.0, 0.0],
        q_goal=[None, LANE, 0.0, 0.0], v_goal=[None] * 4,
        running_cost=effort_and_time, path_constraints=clear_of_the_parked_car,
        control_bounds=([-2 * FORCE, -TORQUE], [FORCE, TORQUE]),
        state_bounds=([None, -LANE / 2, None, -STEERING], [None, 1.5 * LANE, None, STEERING]),
        duration=(0.5, 8.0))


def main(steps=60, out="dmoc-output"):
    """Solve with ``dmoc optimize``, replay with ``dmoc simulate``; return their exit codes."""
    here = lane_change.__code__.co_filename      # this file (the gallery sets no __file__)
    system = f"{here}:lane_change"
    solved = dmoc_command(["optimize", system, "--param", f"steps={steps}", "--heading", "theta",
                           "--out", str(out), "--animate"])
    replayed = dmoc_command(["simulate", system, "--param", f"steps={steps}", "--heading",
                             "theta", "--controls", f"{out}/lane_change.csv", "--no-plots"])
    return solved, replayed


if __name__ == "__main__":
    main(**vars(example_arguments(__doc__)))
