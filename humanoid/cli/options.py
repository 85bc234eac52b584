"""The options that several commands share: the body a command loads (:func:`model_options`,
:func:`subject_options`, :func:`load_any`), keypoints (:func:`keypoint_options`), and the
names of the motion package's registries, written here so that the parser stays light."""

from __future__ import annotations

import argparse

from ..errors import ModelError
from ..variants import BALL_JOINTS, MASSLESS

__all__ = [
    "BODY_HELP",
    "KEYPOINT_LAYOUTS",
    "MARKER_SETS",
    "MARKER_SET_HELP",
    "SCALE_MODES",
    "keypoint_options",
    "load_any",
    "model_options",
    "segment_length",
    "subject_options",
]

BODY_HELP = (
    "a URDF file, a shipped body (adult_male, adult_female) or an example-robot-data robot "
    "(human, talos...)"
)

# humanoid.motion.scale.MODES (written here: the parser stays light)
SCALE_MODES = ("auto", "static", "walk")
# humanoid.motion.marker_sets.MARKER_SETS' names (written here: the parser stays light)
MARKER_SETS = ("gait2354", "plugin-gait", "clusters")
MARKER_SET_HELP = (
    "where the markers are on the body: a shipped set ("
    + ", ".join(MARKER_SETS)
    + ") or a TOML file; default: the shipped set the labels call for"
)

# humanoid.motion.markers.KEYPOINT_LAYOUTS' names (written here: the parser stays light)
KEYPOINT_LAYOUTS = ("coco17", "h36m17", "body25", "halpe26", "smpl24")


def segment_length(text: str) -> tuple[str, float]:
    name, sep, value = text.partition("=")
    if not sep:
        raise argparse.ArgumentTypeError(f"expected NAME=LENGTH, got {text!r}")
    try:
        return name.strip(), float(value)
    except ValueError:
        raise argparse.ArgumentTypeError(f"length of {name!r} is not a number: {value!r}") from None


def joint_range(text: str) -> tuple[str, tuple[float, float]]:
    """``JOINT=LOWER,UPPER`` [deg] (``ankle_flexion=-50,30``): a subject's range of motion."""
    name, sep, value = text.partition("=")
    parts = value.split(",")
    bad = argparse.ArgumentTypeError(f"expected JOINT=LOWER,UPPER in degrees (ankle_flexion"
                                     f"=-50,30), got {text!r}")  # fmt: skip
    if not sep or len(parts) != 2:
        raise bad
    try:
        return name.strip(), (float(parts[0]), float(parts[1]))
    except ValueError:
        raise bad from None


RANGE_HELP = ("a joint's range of motion for this subject [deg], over the clinical normal: a "
              "kind for both sides (ankle_flexion=-50,30) or one joint (right_knee=10,120); "
              "repeatable")  # fmt: skip


def range_option(parser, what: str = "") -> None:
    """``--range JOINT=LOWER,UPPER`` (repeatable)."""
    parser.add_argument("--range", type=joint_range, action="append", default=[],
                        dest="ranges", metavar="JOINT=LOWER,UPPER",
                        help=RANGE_HELP + what)  # fmt: skip


def subject_options(parser) -> None:
    """The body of a motion command: a person's (height, mass, sex) or a model."""
    parser.add_argument("--height", type=float, help="the subject's stature [m] (with --mass, "
                        "--sex: the body is built for them)")  # fmt: skip
    parser.add_argument("--mass", type=float, help="the subject's mass [kg]")
    parser.add_argument("--sex", choices=("male", "female"), help="the subject's sex")
    parser.add_argument("--model", help=BODY_HELP + " (default: adult_male, or a run's own)")
    range_option(parser, " (a body built by --height/--mass/--sex, or one of the toolkit's)")


def keypoint_options(parser, calibration: str | None = None) -> None:
    """The options of a command that reads keypoints (.npy/.npz, or with ``--calibration``
    a folder of 2D keypoints, named ``calibration`` in the help)."""
    parser.add_argument("--layout", choices=KEYPOINT_LAYOUTS, help="the keypoints' order "
                        "(.npy/.npz keypoints, or 2D keypoints with --calibration)")  # fmt: skip
    parser.add_argument("--rate", type=float, help="keypoints' frame rate [Hz] when they have "
                        "no time (default 30)")  # fmt: skip
    parser.add_argument("--y-up", action="store_true", help="keypoints with Y up (z up "
                        "otherwise)")  # fmt: skip
    if calibration:
        parser.add_argument("--calibration", help="the cameras' calibration (Pose2Sim's TOML): "
                            f"{calibration} is then a folder of OpenPose .json folders, one "
                            "per camera (2D keypoints in --layout at --rate), fitted by "
                            "reprojection error")  # fmt: skip


def model_options(parser, ball_joints: bool = True) -> None:
    """The loading options of the commands that load a model (see ``humanoid.load``)."""
    if ball_joints:
        described = "; ".join(f"{k}: {d}" for k, d in BALL_JOINTS.items())
        parser.add_argument(
            "--ball-joints", choices=list(BALL_JOINTS), default="quaternion", help=described
        )
    parser.add_argument("--massless", choices=list(MASSLESS), default="error",
                        help="joints that move no mass: refuse the model, or lock them into "
                        "their parents")  # fmt: skip
    parser.add_argument("--feet", nargs=2, metavar=("LEFT", "RIGHT"),
                        help="the frames of the soles (found by name if not given)")  # fmt: skip


def load_any(args, ball_joints: str | None = None):
    """The model an argument names (a URDF path, a shipped body's name or an
    example-robot-data robot's name), with the command's loading options."""
    from ..model import load

    name = getattr(args, "model", None)
    if name is None:
        name = getattr(args, "target", None)
    if not isinstance(name, str) or not name.strip():
        raise ModelError(f"no model named (got {name!r}): give a URDF file, a shipped body's "
                         "name or an example-robot-data robot's")  # fmt: skip
    ball = ball_joints if ball_joints else getattr(args, "ball_joints", "quaternion")
    feet = tuple(args.feet) if args.feet else None
    return load(name, ball_joints=ball, feet=feet, massless=args.massless)
