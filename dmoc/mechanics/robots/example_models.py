"""The URDF files shipped with dmoc (package data of the mechanics stage): a double
pendulum, a six-joint arm with the dimensions and masses of a UR5-class industrial arm and
a seven-joint arm with the joint frames and limits of a Panda-class collaborative arm, a
differential-drive base carrying a three-joint arm and a floating satellite carrying a
two-joint arm, all written for dmoc.
"""

import pathlib

from ..._util import checks

# name -> what it is; the files are models/<name>.urdf beside this module
EXAMPLE_MODELS = {
    "double_pendulum": "two 1 kg, 1 m rods about parallel axes, hanging along -z",
    "arm6": "six revolute joints, 21.3 kg with its base, a fixed tool; UR5-class lengths and masses",
    "arm7": "seven revolute joints, 19.8 kg with its base, a fixed hand; Panda-class joint frames and limits",
    "mobile_arm": "a differential-drive base (wheel joints left_wheel and right_wheel, a caster) "
                  "carrying a three-joint arm and a fixed tool, 16.6 kg",
    "space_arm": "a floating satellite (10 kg) carrying a two-joint arm and a fixed tool, 13.3 kg "
                 "(`FloatingBaseRobot`)",
}


def example_urdf(name):
    """The path of a URDF file shipped with dmoc.

    Parameters
    ----------
    name : str
        One of ``EXAMPLE_MODELS``: "double_pendulum", "arm6", "arm7", "mobile_arm" or
        "space_arm".

    Returns
    -------
    pathlib.Path

    Examples
    --------
    >>> example_urdf("arm6").name
    'arm6.urdf'
    """
    checks.choice("name", name, tuple(EXAMPLE_MODELS))
    return pathlib.Path(__file__).parent / "models" / f"{name}.urdf"
