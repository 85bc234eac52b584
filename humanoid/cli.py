"""The ``humanoid`` command line: ``build`` and ``info`` (more subcommands join as they land).

Errors go to stderr as one line, with exit code 2 for bad input and no traceback.
"""

from __future__ import annotations

import argparse
import math
import os
import sys
from pathlib import Path

from .errors import HumanoidError, ModelError
from .variants import BALL_JOINTS, INTEGRATORS, MASSLESS, REGISTRIES

__all__ = ["main"]

BODY_HELP = (
    "a URDF file, a shipped body (adult_male, adult_female) or an example-robot-data robot "
    "(human, talos...)"
)

GAITS = ("person", "human", "welded")  # humanoid walk --gait


def _segment_length(text: str) -> tuple[str, float]:
    name, sep, value = text.partition("=")
    if not sep:
        raise argparse.ArgumentTypeError(f"expected NAME=LENGTH, got {text!r}")
    try:
        return name.strip(), float(value)
    except ValueError:
        raise argparse.ArgumentTypeError(f"length of {name!r} is not a number: {value!r}") from None


def build_parser() -> argparse.ArgumentParser:
    from . import __version__
    from .data import scene_names

    p = argparse.ArgumentParser(
        prog="humanoid", description="Physics-based human body models on Pinocchio."
    )
    p.add_argument("--version", action="version", version=f"humanoid {__version__}")
    sub = p.add_subparsers(dest="command", required=True)

    def command(name, **kw):  # every option's help shows its default
        return sub.add_parser(name, formatter_class=argparse.ArgumentDefaultsHelpFormatter, **kw)

    b = command("build", help="write the URDF body of a person (de Leva 1996)")
    b.add_argument("--height", type=float, required=True, help="stature [m], 0.5-2.5")
    b.add_argument("--mass", type=float, required=True, help="body mass [kg], 10-300")
    b.add_argument("--sex", choices=("male", "female"), required=True)
    b.add_argument(
        "--segment",
        type=_segment_length,
        action="append",
        default=[],
        metavar="NAME=LENGTH",
        help="a measured segment length [m], e.g. thigh=0.45 (repeatable)",
    )
    b.add_argument(
        "--toes",
        action=argparse.BooleanOptionalAction,
        default=True,
        help="split each foot at the metatarsophalangeal joint into a rearfoot and a toes "
        "segment on a hinge (default; --no-toes: one rigid foot, de Leva's)",
    )
    b.add_argument("-o", "--output", required=True, help="URDF file to write")

    i = command("info", help="summarise a model: DoF, joints, segments, mass, CoM, feet")
    i.add_argument("model", help=BODY_HELP)
    _model_options(i)

    s = command("simulate", help="run a scene (TOML) and save the trajectory (.npz)")
    s.add_argument(
        "scene", help="a scene file, or a shipped scene's name: " + ", ".join(scene_names())
    )
    s.add_argument("-o", "--output", default="run.npz", help="trajectory file to write")
    s.add_argument("--duration", type=float, help="override the scene's duration [s]")
    s.add_argument("--quiet", action="store_true", help="no progress bar")

    w = command("walk", help="walk a body in forward simulation (torque control)")
    w.add_argument("--model", default="adult_male", help=BODY_HELP)
    w.add_argument("--steps", type=int, default=10, help="number of steps, 2-1000")
    w.add_argument("--speed", type=float, help="walking speed [m/s] (sets the step length)")
    w.add_argument("--step-length", type=float, help="step length [m]")
    w.add_argument("--mu", type=float, default=0.8, help="friction coefficient of the checks")
    w.add_argument("-o", "--output", default="walk.npz", help="trajectory file to write")
    w.add_argument("--html", help="also write the viewer as one HTML file")
    w.add_argument("--figure", help="figure file (PNG); default: next to the trajectory")
    w.add_argument("--quiet", action="store_true", help="no progress bar")
    w.add_argument(
        "--gait",
        choices=GAITS,
        default="person",
        help="person: the body's gait cycle optimised through its contact dynamics (shipped "
        "or cached; else optimised once, a few minutes, with casadi), tracked on the rigid "
        "ground, heel to toe; human: a person's joint angles fitted kinematically to the "
        "body and tracked (walks from standing and along curves); welded: flat feet welded "
        "at each step (any humanoid)",
    )
    w.add_argument(
        "--from-standing",
        action="store_true",
        help="start standing still and stop standing, the feet side by side. person: two "
        "steps to start and two to stop, optimised into and out of the cycle (shipped for "
        "the default bodies at their free speed; else optimised once, a few minutes), and "
        "(STEPS - 5) // 2 whole strides (at least one) between; human: the last of --steps "
        "brings the feet together (it stops from 0.8 m/s, not from a person's free speed)",
    )
    w.add_argument(
        "--radius",
        type=float,
        help="walk along a circle of this radius [m], positive turning left. person: a "
        "stride optimised along the circle, its speed the optimum's (at least 1 m; shipped "
        "for the default bodies at 2 m, else optimised once, a few minutes); human: the "
        "fitted cycle bent onto it (at least 0.5; a 2 m circle walks at 0.8 m/s)",
    )
    w.add_argument(
        "--report",
        help="(--gait person, human) the gait report: angles, moments, powers "
        "and forces over the normative bands, and the table (PNG)",
    )
    w.add_argument("--integrator", choices=list(INTEGRATORS),
                   help="(--gait welded) the plant's integrator (humanoid variants; default "
                   "semi_implicit_euler)")  # fmt: skip
    w.add_argument("--dt", type=float, default=1e-3, help="simulation and control step [s]")
    w.add_argument("--control-dt", type=float,
                   help="(--gait welded) the QP's period [s], a multiple of --dt (default 8 ms; "
                   "between QP ticks the contact forces are held)")  # fmt: skip
    w.add_argument(
        "--drop", type=float, help="(--gait welded) pelvis lowered before walking [m] (0.04)"
    )
    w.add_argument(
        "--push",
        action="append",
        default=[],
        metavar="DIRECTION:FRACTION",
        help="(--gait person, human) push the pelvis for 0.1 s at a mid-stance (the third stride), "
        "FRACTION of body weight, DIRECTION forward, backward, left or right; repeatable",
    )
    w.add_argument(
        "--largest-push",
        choices=("forward", "backward", "left", "right"),
        help="(--gait person, human) search the largest such push the walk survives (a walk "
        "per try)",
    )
    w.add_argument("--mot", help="(--gait person, human) also write the walk as OpenSim reads it: "
                   "coordinates (this .mot, Rajagopal's names) and ground forces (<stem>_grf.mot "
                   "and its .xml)")  # fmt: skip
    w.add_argument("--record-rate", type=float, default=100.0,
                   help="(--gait person, human) samples per second recorded (1000 at --dt 0.001: "
                   "every step, for inverse dynamics that gives back the torques)")  # fmt: skip
    _model_options(w, ball_joints=False)

    v = command("view", help="show a model or a run in the browser (live, or as HTML)")
    v.add_argument("target", help="a URDF, an example-robot-data name, a run (.npz), or joint "
                   "coordinates (.mot/.sto, shown on --model)")  # fmt: skip
    v.add_argument("--html", help="write one self-contained HTML file instead of serving")
    v.add_argument("--speed", type=float, default=1.0, help="playback speed (1 = real time)")
    v.add_argument("--fps", type=float, default=30.0, help="animation frames per second")
    v.add_argument("--force-scale", type=float, default=0.5, help="arrow length per body weight")
    for name in ("forces", "com", "footprints", "ground", "markers"):
        v.add_argument(f"--no-{name}", action="store_true", help=f"hide the {name} overlay")
    v.add_argument("--camera", choices=("oblique", "side", "front", "top"), default="oblique",
                   help="the view it opens with: oblique, side (along the left-right axis), "
                   "front (along the walking direction), top (the whole path); the camera "
                   "follows the body but in top (the page: a button and a key each)")  # fmt: skip
    v.add_argument("--markers", help="the trial's markers (.trc, .c3d; keypoints .npy/.npz "
                   "with --layout) drawn with the motion: measured, on the body, and the "
                   "residuals between")  # fmt: skip
    v.add_argument("--marker-set", help=MARKER_SET_HELP)
    _keypoint_options(v)
    v.add_argument("--model", help=BODY_HELP + " (for .mot/.sto coordinates; default "
                   "adult_male)")  # fmt: skip
    v.add_argument("--map", help="the coordinates' model (gait2392, gait2354, rajagopal, TOML; "
                   "default: told from the file)")  # fmt: skip
    _model_options(v)

    x = command("export", help="export a model to another simulator's format")
    x.add_argument("model", help=BODY_HELP)
    x.add_argument(
        "--mjcf",
        required=True,
        help="MuJoCo MJCF file to write: a model to "
        "simulate (a floor, collisions, joint ranges, a motor per degree of freedom)",
    )
    x.add_argument("--mu", type=float, default=0.8, help="the floor's friction (default 0.8)")
    x.add_argument("--no-floor", action="store_true", help="no floor and no collisions")
    x.add_argument("--dt", type=float, default=1e-3, help="MuJoCo's timestep [s] (default 1 ms)")
    _model_options(x)

    k = command("ik", help="inverse kinematics of markers (.trc, .c3d), a BVH's joints or "
                "keypoints (.npy/.npz)")  # fmt: skip
    k.add_argument("markers", help="marker trajectories (.trc, .c3d), a BVH motion or keypoints "
                   "(.npy (frames, k, 3), or .npz with 'points' and 'time') [m]")  # fmt: skip
    _subject_options(k)
    k.add_argument("--marker-set", help=MARKER_SET_HELP)
    k.add_argument("--register", action="store_true", help="place the technical (cluster) "
                   "markers where the anatomical ones' fit finds them, then fit all")  # fmt: skip
    k.add_argument("--ball-ranges", action="store_true", help="keep the ball joints (hips, "
                   "spine, shoulders, neck) in their ranges too, reported as the hinges' are "
                   "(default: the hinges only)")  # fmt: skip
    k.add_argument("--smoothing", type=float,
                   help="the joints' pull towards the frame before, on their velocity [s^2] "
                   "(default: 0 with 40 markers or more, 1e-7 with fewer: keypoints)")  # fmt: skip
    k.add_argument("--static", help="a static trial (.trc, .c3d) to register the technical "
                   "markers on (implies --register)")  # fmt: skip
    _keypoint_options(k, calibration="MARKERS")
    k.add_argument("--map", help="the coordinates' names: rajagopal (default), gait2392, "
                   "gait2354")  # fmt: skip
    k.add_argument("-o", "--output", default="ik.mot", help="coordinates to write (.mot, .csv)")
    k.add_argument("--figure", help="residuals figure (PNG); default: next to the output")
    k.add_argument("--html", help="also write the fitted motion's viewer (one HTML file)")
    k.add_argument("--save-markers", help="write the marker set as used (TOML)")
    k.add_argument("--quiet", action="store_true", help="no progress bar")

    sc = command("scale", help="scale a body to a subject from a static trial (or a walk), "
                 "as OpenSim's ScaleTool: the URDF and its placed marker set")  # fmt: skip
    sc.add_argument("static", help="the static trial (.trc, .c3d): the subject standing still; "
                    "or a walk (told by its markers moving, see --mode)")  # fmt: skip
    sc.add_argument("--mass", required=True, help="the subject's mass [kg], or 'auto': from "
                    "the C3D's force plates (a single stance's impulse)")  # fmt: skip
    sc.add_argument("--mode", choices=SCALE_MODES, default="auto", help="static: a standing "
                    "trial's mean; walk: medians, the markers placed on the walk's frames "
                    "fitted; auto: walk if the markers move over 5 cm")  # fmt: skip
    sc.add_argument("--fit-frames", type=int, help="frames fitted to measure, place and report "
                    "(default: 10 of a static trial, 60 of a walk)")  # fmt: skip
    sc.add_argument("--height", type=float, help="the subject's stature [m] (default: the "
                    "measured segments', sole to vertex)")  # fmt: skip
    sc.add_argument("--sex", choices=("male", "female"), help="default: the unscaled body's")
    sc.add_argument("--model", help="the unscaled body, one of the toolkit's (default: "
                    "adult_male; adult_female with --sex female)")  # fmt: skip
    sc.add_argument("--marker-set", help="where the markers are on the unscaled body (TOML; "
                    "default: the toolkit's set); 'fixed = true' keeps one in place")  # fmt: skip
    sc.add_argument("--time-range", nargs=2, type=float, metavar=("START", "END"),
                    help="the frames to use [s] (default: all)")  # fmt: skip
    sc.add_argument("-o", "--output", required=True, help="the scaled body (URDF); its marker "
                    "set is written next to it, <name>_markers.toml")  # fmt: skip

    tr = command("track", help="follow a motion in forward simulation by joint torques "
                 "(physics-based tracking)")  # fmt: skip
    tr.add_argument("motion", help="coordinates (.mot/.sto), a run (.npz), or markers (.trc, "
                    ".c3d) and keypoints (.npy, .npz with --layout): fitted first")  # fmt: skip
    _subject_options(tr)
    tr.add_argument("--loads", help="measured ground forces (.mot, or a C3D's force plates): "
                    "when each foot is down")  # fmt: skip
    tr.add_argument("--loads-xml", help="their ExternalLoads .xml")
    tr.add_argument(
        "--loads-side",
        action="append",
        default=[],
        metavar="PREFIX=SIDE",
        help="the foot of a load column prefix (repeatable)",
    )
    tr.add_argument("--map", help="the coordinates' model (gait2392, gait2354, rajagopal, TOML)")
    tr.add_argument("--no-floor", action="store_true", help="keep the motion's height")
    _keypoint_options(tr, calibration="MOTION")
    tr.add_argument("--marker-set", help=MARKER_SET_HELP)
    tr.add_argument("--register", action="store_true", help="place the technical (cluster) "
                    "markers first, as for ik")  # fmt: skip
    tr.add_argument("--static", help="a static trial to register the technical markers on")
    tr.add_argument("--floor", choices=("auto", "fit", "motion"), default="auto",
                    help="the floor the motion is followed on: fitted to its stances ('fit'), "
                    "the plane of its lowest sole point ('motion'), or 'auto' (default): the "
                    "fitted one if it has a treadmill's belt, a tilt over 0.5 deg or a height "
                    "over 5 mm")  # fmt: skip
    tr.add_argument("--reduce", action="store_true", help="reduce the pelvis residuals first "
                    "(small changes to the motion, as OpenSim's RRA; under --loads, or loads "
                    "estimated on the floor)")  # fmt: skip
    tr.add_argument("--cutoff", type=float, help="low-pass cutoff of the reference [Hz] (0: "
                    "none; default: Winter's residual analysis of the motion)")  # fmt: skip
    tr.add_argument("--dt", type=float, default=1e-3, help="simulation step [s]")
    tr.add_argument("-o", "--output", default="tracked.npz", help="the run to write (.npz)")
    tr.add_argument("--mot", help="also write it as OpenSim files (coordinates, ground forces)")
    tr.add_argument("--figure", help="figure (PNG); default: next to the run")
    tr.add_argument("--html", help="also write the viewer (one HTML file)")
    tr.add_argument("--quiet", action="store_true", help="no progress bar")

    d = command("id", help="inverse dynamics of a motion (OpenSim .mot/.sto, or a run .npz)")
    d.add_argument("motion", help="joint coordinates (.mot/.sto, OpenSim's gait models' names) "
                   "or a run (.npz: its own ground forces are the loads)")  # fmt: skip
    _subject_options(d)
    d.add_argument("--loads", help="external loads (.mot, OpenSim's layout: "
                   "<prefix>force_vx..., <prefix>force_px..., <prefix>torque_x...), or a C3D: "
                   "its force plates, given to the feet by its markers")  # fmt: skip
    d.add_argument("--loads-xml", help="the loads' ExternalLoads .xml (which foot each is on; "
                   "default: the .xml of the same name next to them)")  # fmt: skip
    d.add_argument(
        "--loads-side",
        action="append",
        default=[],
        metavar="PREFIX=SIDE",
        help="the foot (left, right) of a load column prefix (repeatable)",
    )
    d.add_argument("--markers", help="the trial's markers (.trc, .c3d): each foot's load is "
                   "carried with the body's foot, by where the foot's markers show the "
                   "recorded foot was")  # fmt: skip
    d.add_argument("--marker-set", help="where the markers are on the body (TOML; default: "
                   "the toolkit's set)")  # fmt: skip
    d.add_argument("--reduce", action="store_true", help="reduce the pelvis residuals first: "
                   "small changes to the motion, the body's mass and its trunk's mass centre "
                   "(as OpenSim's RRA); the moments are the reduced motion's")  # fmt: skip
    d.add_argument("--reduced", help="write the reduced motion here (.mot, the input's map)")
    d.add_argument("--estimate-loads", action="store_true",
                   help="estimate the feet's ground forces from the motion (as without "
                   "--loads) and, with --loads, compare")  # fmt: skip
    d.add_argument("--map", help="the coordinates' model: gait2392, gait2354, rajagopal, or a "
                   "TOML map of your own (default: told from the file)")  # fmt: skip
    d.add_argument(
        "--cutoff",
        type=float,
        default=6.0,
        help="low-pass cutoff [Hz] for the motion and the loads (0: none)",
    )
    d.add_argument("--velocity", choices=("central", "backward"), default="central",
                   help="velocities from central differences, or backward ones (how a "
                   "semi-implicit Euler simulation defines them: its run, recorded at every "
                   "step, gives back its torques exactly)")  # fmt: skip
    d.add_argument("--rate", type=float, help="resample to this rate [Hz] (default: the "
                   "motion's own)")  # fmt: skip
    d.add_argument("--no-floor", action="store_true", help="keep the motion's height as it is "
                   "(default: its lowest sole point is put on the floor)")  # fmt: skip
    d.add_argument(
        "-o", "--output", default="id.sto", help="generalised forces to write (.sto, or .csv)"
    )
    d.add_argument("--figure", help="figure (PNG); default: next to the output")
    d.add_argument("--html", help="also write the motion's viewer, the loads drawn (one HTML "
                   "file)")  # fmt: skip

    g = command("loads", help="a C3D's force plates (types 1-4) as the feet's loads, written "
                "as OpenSim's external loads (.mot and its ExternalLoads .xml)")  # fmt: skip
    g.add_argument("c3d", help="the trial (.c3d): its plates, and its markers to tell the feet")
    g.add_argument("-o", "--output", help="the loads to write (.mot; default: <trial>_grf.mot "
                   "here); the .xml goes next to it")  # fmt: skip
    g.add_argument("--threshold", type=float, default=20.0, help="the normal force [N] above "
                   "which a plate is in contact (it ends below half of it)")  # fmt: skip
    g.add_argument("--plate-side", action="append", default=[], metavar="PLATE=SIDE",
                   help="the foot (left, right) of every contact on a plate (its number, 1 "
                   "for the first), whatever the markers say (repeatable)")  # fmt: skip

    rp = command("report", help="a gait lab's report of a person's own trial: angles, moments "
                 "and powers over the gait cycle, left and right, over the normative band, and "
                 "the spatiotemporal table (PNG)")  # fmt: skip
    rp.add_argument("trial", help="the trial's coordinates (.mot/.sto: humanoid ik's or "
                    "OpenSim's IK, its gait models' names), or a C3D with markers (and force "
                    "plates): inverse kinematics and dynamics run on the body")  # fmt: skip
    rp.add_argument("--moments", help="its generalised forces (.sto of humanoid id or OpenSim's "
                    "ID, N m): moments and powers (without: kinematics only)")  # fmt: skip
    rp.add_argument("--loads", help="the ground's loads (external loads .mot, or a C3D's force "
                    "plates): the events and the ground reaction forces (without: events from "
                    "the feet's motion)")  # fmt: skip
    rp.add_argument("--loads-xml", help="the loads' ExternalLoads .xml")
    rp.add_argument("--loads-side", action="append", default=[], metavar="PREFIX=SIDE",
                    help="the foot (left, right) of a load column prefix (repeatable)")  # fmt: skip
    rp.add_argument("--events", help="a C3D whose EVENT group has the foot strikes and foot "
                    "offs: they come first")  # fmt: skip
    rp.add_argument("--height", type=float, help="the subject's stature [m] (with --mass, "
                    "--sex: the body is built for them)")  # fmt: skip
    rp.add_argument("--mass", type=float, help="the subject's mass [kg]: the moments and powers "
                    "are per kg of it (default: the body's)")  # fmt: skip
    rp.add_argument("--sex", choices=("male", "female"), help="the subject's sex")
    rp.add_argument("--model", help=BODY_HELP + " (default: adult_male)")
    rp.add_argument("--map", help="the coordinates' model: gait2392, gait2354, rajagopal, or a "
                    "TOML map (default: told from the file)")  # fmt: skip
    rp.add_argument("--speed", type=float, help="the walking speed [m/s] that picks the "
                    "normative band (a treadmill's belt; default: the strides')")  # fmt: skip
    rp.add_argument("--threshold", type=float, default=20.0, help="a foot's contact: its "
                    "vertical force above this [N] (it ends below half of it)")  # fmt: skip
    rp.add_argument("--no-floor", action="store_true", help="keep the motion's height as it is")
    rp.add_argument("--marker-set", help=MARKER_SET_HELP + " (a C3D trial)")
    rp.add_argument("-o", "--output", default="report.png", help="the report to write (PNG)")

    command("variants", help="list the integrators, formulations, backends, contact kinds... "
            "that scenes and options accept")  # fmt: skip

    bench = command(
        "bench",
        help="benchmarks: step cost, walking cost, work-precision "
        "(accuracy), motion against OpenSim",
    )
    bench.add_argument(
        "kind",
        choices=("step", "walk", "scaling", "accuracy", "motion"),
        help="step: one step against Pinocchio (and MuJoCo on the ground); walk: a simulated "
        "second of walking, its parts and the bare plant; scaling: cost against nv and the "
        "contacts; motion: inverse dynamics and "
        "kinematics against OpenSim 4",
    )
    bench.add_argument("--quick", action="store_true", help="fewer repetitions")
    bench.add_argument("-o", "--output", default="results/bench", help="folder for the CSV")
    from .study.commands import add_sweep_parser

    add_sweep_parser(command)
    return p


def _subject_options(parser) -> None:
    """The body of a motion command: a person's (height, mass, sex) or a model."""
    parser.add_argument("--height", type=float, help="the subject's stature [m] (with --mass, "
                        "--sex: the body is built for them)")  # fmt: skip
    parser.add_argument("--mass", type=float, help="the subject's mass [kg]")
    parser.add_argument("--sex", choices=("male", "female"), help="the subject's sex")
    parser.add_argument("--model", help=BODY_HELP + " (default: adult_male, or a run's own)")


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


def _keypoint_options(parser, calibration: str | None = None) -> None:
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


def _model_options(parser, ball_joints: bool = True) -> None:
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


OUTPUTS = {  # the options of each command that name a file or folder to write
    "build": ("output",),
    "simulate": ("output",),
    "walk": ("output", "html", "figure", "mot"),
    "view": ("html",),
    "export": ("mjcf",),
    "id": ("output", "figure", "html"),
    "ik": ("output", "figure", "html", "save_markers"),
    "track": ("output", "figure", "html", "mot"),
    "scale": ("output",),
    "loads": ("output",),
    "report": ("output",),
    "bench": ("output",),
    "sweep": ("output",),
}


def check_output(path: str, option: str, folder: bool = False) -> Path:
    """An output path that can be written, checked before any work starts: not an existing
    directory (or an existing file, for a folder), its parent creatable and writable."""
    p = Path(path)
    if folder:
        if p.exists() and not p.is_dir():
            raise HumanoidError(f"{option} {path}: exists and is not a folder")
        parent = p
    else:
        if p.is_dir():
            raise HumanoidError(f"{option} {path}: is a folder; give a file name")
        parent = p.parent
    try:
        parent.mkdir(parents=True, exist_ok=True)
    except OSError as exc:
        raise HumanoidError(f"{option} {path}: cannot create {parent}: {exc.strerror}") from None
    if not os.access(parent, os.W_OK):
        raise HumanoidError(f"{option} {path}: {parent} is not writable")
    if p.exists() and not folder and not os.access(p, os.W_OK):
        raise HumanoidError(f"{option} {path}: the file is not writable")
    return p


def main(argv: list[str] | None = None) -> int:
    """Run the command line; returns the exit code (0 done, 2 bad input, 3 a run that did
    not complete or failed its checks). A closed output pipe (``| head``) ends it quietly."""
    args = build_parser().parse_args(argv)
    try:
        for name in OUTPUTS.get(args.command, ()):
            value = getattr(args, name, None)
            if value is not None:
                option = "--" + name.replace("_", "-") if name != "output" else "-o"
                check_output(value, option, folder=args.command in ("bench", "sweep"))
        return _dispatch(args)
    except HumanoidError as exc:
        print(f"humanoid {args.command}: error: {exc}", file=sys.stderr)
        return 2
    except BrokenPipeError:
        # the reader went away (``humanoid info ... | head``): stop writing, no traceback
        devnull = os.open(os.devnull, os.O_WRONLY)
        os.dup2(devnull, sys.stdout.fileno())
        return 0


def _dispatch(args) -> int:
    if args.command == "build":
        return _build(args)
    if args.command == "info":
        return _info(args)
    if args.command == "simulate":
        return _simulate(args)
    if args.command == "walk":
        return _walk(args)
    if args.command == "view":
        return _view(args)
    if args.command == "export":
        from .export import write_mjcf

        h = load_any(args)
        path = write_mjcf(h, args.mjcf, mu=None if args.no_floor else args.mu, timestep=args.dt)
        floor = "no floor" if args.no_floor else f"a floor (friction {args.mu:g})"
        print(
            f"wrote {path}: {h.model.nv - 6} joint degrees of freedom, each with a motor; "
            f"joint ranges on; {floor}; MuJoCo's semi-implicit Euler at {args.dt:g} s"
        )
        return 0
    if args.command == "variants":
        return _variants(args)
    if args.command == "id":
        from .motion.commands import run_id

        return run_id(args)
    if args.command == "ik":
        from .motion.commands import run_ik

        return run_ik(args)
    if args.command == "scale":
        from .motion.commands import run_scale

        return run_scale(args)
    if args.command == "track":
        from .motion.commands import run_track

        return run_track(args)
    if args.command == "loads":
        from .motion.commands import run_loads

        return run_loads(args)
    if args.command == "report":
        from .motion.commands import run_report

        return run_report(args)
    if args.command == "sweep":
        from .study.commands import run_sweep

        return run_sweep(args)
    if args.command == "bench":
        if args.kind == "motion":
            from .bench.motion import run_motion_benchmark

            return run_motion_benchmark(quick=args.quick, out=args.output)
        if args.kind == "scaling":
            from .bench.scaling import run_scaling_benchmark

            return run_scaling_benchmark(quick=args.quick, out=args.output)
        if args.kind == "walk":
            from .bench.walk import run_walk_benchmark

            return run_walk_benchmark(quick=args.quick, out=args.output)
        if args.kind == "accuracy":
            from .bench.accuracy import run_accuracy_benchmark

            return run_accuracy_benchmark(quick=args.quick, out=args.output)
        from .bench.step import run_step_benchmark

        return run_step_benchmark(quick=args.quick, out=args.output)
    return 1  # pragma: no cover - argparse rejects unknown commands


def _build(args) -> int:
    from .anthropometry import BodyParameters
    from .body import write_urdf

    params = BodyParameters(args.height, args.mass, args.sex, dict(args.segment), args.toes)
    path = write_urdf(params, args.output)
    toes = ", toes" if params.toes else ""
    print(f"wrote {path} ({params.sex}, {params.height} m, {params.mass} kg{toes})")
    return 0


def load_any(args, ball_joints: str | None = None):
    """The model an argument names (a URDF path, a shipped body's name or an
    example-robot-data robot's name), with the command's loading options."""
    from .model import load

    name = getattr(args, "model", None)
    if name is None:
        name = getattr(args, "target", None)
    if not isinstance(name, str) or not name.strip():
        raise ModelError(f"no model named (got {name!r}): give a URDF file, a shipped body's "
                         "name or an example-robot-data robot's")  # fmt: skip
    ball = ball_joints or getattr(args, "ball_joints", "quaternion")
    feet = tuple(args.feet) if args.feet else None
    return load(name, ball_joints=ball, feet=feet, massless=args.massless)


def _variants(args) -> int:
    for registry in REGISTRIES:
        where = f" (scene key {registry.key})" if registry.key else ""
        print(f"{registry.what}{where}")
        width = max(map(len, registry))
        for name, description in registry.items():
            print(f"  {name:<{width}}  {description}")
    return 0


def _info(args) -> int:
    print(summary(load_any(args)))
    return 0


def _simulate(args) -> int:
    from .scene import Scene
    from .simulation import simulate

    scene = Scene.load(args.scene)
    if args.duration is not None:
        scene = scene.replace(duration=args.duration)
    traj = simulate(scene, quiet=args.quiet)
    path = traj.save(args.output)
    print(run_summary(traj))
    print(f"saved        {path}")
    if traj.status != "completed":
        print(f"humanoid simulate: {traj.status}: {traj.metadata['message']}", file=sys.stderr)
        return 3
    return 0


def _walk(args) -> int:
    from .walking import GaitParameters, format_summary, plot_walk, walk
    from .walking.plan import MAX_STEPS

    ranges = {  # option: (value, whether 0 is allowed, upper bound)
        "--speed": (args.speed, False, 3.0),
        "--step-length": (args.step_length, False, 1.0),
        "--mu": (args.mu, True, 10.0),
        "--dt": (args.dt, False, 0.01),
        "--drop": (args.drop, False, 0.2),
    }
    for option, (value, zero, hi) in ranges.items():
        if value is None:
            continue
        above = value >= 0 if zero else value > 0
        if not (math.isfinite(value) and above and value <= hi):
            raise HumanoidError(
                f"{option} must be in {'[' if zero else '('}0, {hi:g}], got {value}"
            )
    if args.step_length is not None and args.speed is not None:
        raise HumanoidError("give --speed or --step-length, not both")
    if not 2 <= args.steps <= MAX_STEPS:
        raise HumanoidError(f"--steps must be in [2, {MAX_STEPS}], got {args.steps}")
    if args.gait != "welded":
        return _walk_on_ground(args)
    given = [o for o, v in (("--report", args.report), ("--push", args.push),
                            ("--largest-push", args.largest_push), ("--mot", args.mot),
                            ("--record-rate", args.record_rate != 100.0)) if v]  # fmt: skip
    if given:
        raise HumanoidError(f"{', '.join(given)}: only with --gait person or human")
    _on_ground_only(args)
    h = load_any(args, ball_joints="quaternion")
    kw = {"steps": args.steps}
    if args.step_length is not None:
        kw["step_length"] = args.step_length
    gait = GaitParameters.for_speed(args.speed, **kw) if args.speed else GaitParameters(**kw)
    result = walk(h, gait, dt=args.dt, mu=args.mu, quiet=args.quiet,
                  drop=0.04 if args.drop is None else args.drop, control_dt=args.control_dt,
                  integrator=args.integrator or "semi_implicit_euler")  # fmt: skip
    path = result.trajectory.save(args.output)
    figure = plot_walk(result, args.figure or Path(args.output).with_suffix(".png"))
    print(format_summary(result))
    print(f"\nsaved        {path}\nfigure       {figure}")
    if args.html:
        from .viewer import export_html

        page = export_html(h, args.html, traj=result.trajectory, title="walk")
        print(f"viewer       {page}")
    if not result.ok:
        failed = [k for k, c in result.checks.items() if not c["ok"]]
        print(f"humanoid walk: checks failed: {', '.join(failed)}", file=sys.stderr)
        period = result.trajectory.metadata["control_period"]
        if period > args.dt * 1.5:
            print(f"humanoid walk: the QP ran every {period * 1e3:g} ms with the contact forces "
                  f"held in between; --control-dt {args.dt:g} solves it at every step (a "
                  "marginal walk, such as g1's, may need it)", file=sys.stderr)  # fmt: skip
        return 3
    return 0


def _ground_walk_pushes(args) -> list[tuple[str, float]]:
    """The options of ``humanoid walk --gait person|human`` checked, and its ``--push`` es as
    (direction, fraction of body weight)."""
    from .walking.gait import DIRECTIONS

    given = [o for o, v in (("--step-length", args.step_length), ("--figure", args.figure),
                            ("--drop", args.drop), ("--integrator", args.integrator),
                            ("--control-dt", args.control_dt))
             if v is not None]  # fmt: skip
    if given:
        raise HumanoidError(f"{', '.join(given)}: only with --gait welded")
    pushes = []
    for spec in args.push:
        direction, _, fraction = spec.partition(":")
        try:
            value = float(fraction)
        except ValueError:
            value = math.nan
        if direction not in DIRECTIONS or not 0.0 < value <= 2.0:
            raise HumanoidError(
                f"--push {spec!r}: give DIRECTION:FRACTION, DIRECTION one of "
                f"{', '.join(DIRECTIONS)}, FRACTION of body weight in (0, 2]"
            )
        pushes.append((direction, value))
    if args.largest_push and (args.radius is not None or args.from_standing):
        raise HumanoidError("--largest-push: a straight walk's; not with --radius or "
                            "--from-standing")  # fmt: skip
    if pushes and args.radius is not None:
        raise HumanoidError("--push: a push is along the room's axes; not with --radius")
    if pushes and args.steps < 8:
        raise HumanoidError(
            f"--push acts in the third stride: give --steps 8 or more, not {args.steps}"
        )
    least = 3 if args.gait == "human" else 7
    if args.from_standing and (pushes or args.steps < least or args.radius is not None):
        raise HumanoidError(
            f"--from-standing: give --steps {least} or more, and no --push or --radius"
        )
    if not (math.isfinite(args.record_rate) and 0.0 < args.record_rate * args.dt <= 1.0 + 1e-9):
        raise HumanoidError(
            f"--record-rate must be positive and at most 1/dt = {1.0 / args.dt:g} Hz, got "
            f"{args.record_rate:g}"
        )
    return pushes


def _walk_on_ground(args) -> int:
    """``humanoid walk --gait person|human``: a person's walk on the rigid ground."""
    from .walking.gait import analyse, largest_push, pelvis_push
    from .walking.report import format_gait_table, plot_gait_report

    pushes = _ground_walk_pushes(args)
    h = load_any(args, ball_joints="quaternion")
    cycle, walker = _ground_walker(args, h)
    if args.largest_push:

        def tried(fraction, survived):
            print(f"push {fraction:.3f} BW {args.largest_push:8s} "
                  f"{'survived' if survived else 'fell'}", flush=True)  # fmt: skip

        found = largest_push(h, args.largest_push, cycle, walk=walker, progress=tried)
        fell = f"{found.fell:.3f} BW" if found.fell is not None else "none tried fell"
        print(f"largest push survived  {found.survived:.3f} BW {found.direction} "
              f"(0.1 s at mid-stance; smallest fall: {fell})")  # fmt: skip
        return 0
    kw = {"from_standing": args.from_standing, "radius": args.radius}
    walk = walker(args.steps, [pelvis_push(h, cycle, f, d) for d, f in pushes], quiet=args.quiet,
                  record_rate=args.record_rate, **kw)  # fmt: skip
    h = walk.body or h  # the body that walked (the fitted cycle's: its toes locked)
    path = walk.trajectory.save(args.output)
    analysis = analyse(h, walk)
    meta = walk.trajectory.metadata
    print(f"status       {meta['status']}" + (f": {meta['message']}" if meta["message"] else ""))
    print(f"real time    {walk.real_time_factor:.2f} x ({walk.wall_time:.0f} s of wall time)")
    print(format_gait_table(analysis))
    print(f"\nsaved        {path}")
    if args.mot:
        from .motion.export import write_opensim

        for written in write_opensim(h, walk.trajectory, args.mot):
            print(f"opensim      {written}")
    if args.report:
        print(f"report       {plot_gait_report(analysis, args.report)}")
    if args.html:
        from .viewer import export_html

        page = export_html(h, args.html, traj=walk.trajectory, title="walk")
        print(f"viewer       {page}")
    speed = cycle.speed if args.gait == "person" else cycle.gait["speed"]
    if not walk.completed and args.from_standing and args.gait == "human":
        print(f"humanoid walk: it did not stop standing from {speed:.2f} m/s; "
              "it stops from 0.8 m/s (--speed 0.8), not yet from a person's free speed; "
              "--gait person starts and stops at it", file=sys.stderr)  # fmt: skip
    elif not walk.completed and args.speed is None and not pushes:
        print(f"humanoid walk: it fell at its free speed ({speed:.2f} m/s, a "
              "person's for its leg length); a robot may walk slower: try --speed 0.6",
              file=sys.stderr)  # fmt: skip
    return 0 if walk.completed else 3


def _on_ground_only(args) -> None:
    given = [o for o, v in (("--from-standing", args.from_standing),
                            ("--radius", args.radius is not None)) if v]  # fmt: skip
    if given:
        raise HumanoidError(f"{', '.join(given)}: only with --gait person or human")


def _ground_walker(args, h):
    """The cycle a ``--gait person|human`` walk follows and ``walk(steps, pushes, **kw)`` that
    walks it (``kw``: quiet, record_rate; with human, from_standing and radius)."""
    if args.gait == "human":
        from .walking.gait import walk_on_ground
        from .walking.reference import fit_cycle

        cycle = fit_cycle(h, args.speed)

        def walk(steps, pushes, **kw):
            return walk_on_ground(h, steps=steps, cycle=cycle, dt=args.dt, mu=args.mu,
                                  pushes=pushes, **kw)  # fmt: skip

        return cycle, walk
    from .walking.person import walk_cycle, walk_from_standing

    cycle = person_gait(h, args.speed, quiet=args.quiet)

    def walk(steps, pushes, from_standing=False, radius=None, **kw):
        if from_standing:  # two steps to start, two to stop, whole strides between
            strides = max(1, (steps - 5) // 2)
            return walk_from_standing(h, cycle, strides, dt=args.dt, mu=args.mu, **kw)
        return walk_cycle(h, cycle, steps, dt=args.dt, mu=args.mu, pushes=pushes,
                          radius=radius, **kw)  # fmt: skip

    return cycle, walk


def person_gait(h, speed=None, quiet: bool = False):
    """The body's optimised gait cycle (tracking objective) at ``speed`` (default its free
    speed): shipped with the package or in the user's cache, else optimised now (casadi) and
    cached, saying so."""
    from .optimal.cycle import cache_dir, default_speed, stored_gait

    gait = stored_gait(h, speed)
    if gait is not None:
        return gait
    speed = round(default_speed(h) if speed is None else speed, 2)
    try:
        from .optimal.gait import gait_cycle
    except ImportError as exc:
        raise HumanoidError(
            f"no optimised gait cycle of {h.source} at {speed:.2f} m/s is shipped or cached, "
            f"and optimising one needs the optimal-control extra ({exc})"
        ) from exc
    if not quiet:
        print(f"optimising the gait cycle of {h.source} at {speed:.2f} m/s (once, a few "
              f"minutes; cached in {cache_dir()})", flush=True)  # fmt: skip
    return gait_cycle(h, speed)


def _view(args) -> int:
    from .viewer import LiveViewer, Overlays, SceneView, check_playback, export_html, humanoid_for

    check_playback(args.speed, args.fps)
    if not 0.0 <= args.force_scale < math.inf:
        raise HumanoidError(f"--force-scale {args.force_scale}: a length per body weight >= 0")
    overlays = Overlays(
        forces=not args.no_forces,
        com=not args.no_com,
        footprints=not args.no_footprints,
        ground=not args.no_ground,
        force_scale=args.force_scale,
        markers=not args.no_markers,
    )
    traj = None
    suffix = Path(args.target).suffix.lower()
    if suffix == ".npz":
        from .simulation import Trajectory

        traj = Trajectory.load(args.target)
        h = humanoid_for(traj)
    elif suffix in (".mot", ".sto"):
        h, traj = _coordinates_run(args)
    else:
        h = load_any(args)
    markers = marker_set = None
    if args.markers:
        if traj is None:
            raise HumanoidError("--markers are drawn with a motion: a run (.npz) or joint "
                                "coordinates (.mot/.sto)")  # fmt: skip
        from .motion.commands import marker_set_of, markers_file

        chosen, markers = marker_set_of(h, markers_file(args.markers, args), args.marker_set,
                                        crop=False)  # fmt: skip
        marker_set = chosen.markers
    title = Path(args.target).stem
    if args.html:
        path = export_html(h, args.html, traj=traj, overlays=overlays, speed=args.speed,
                           fps=args.fps, title=title, markers=markers, marker_set=marker_set,
                           camera=args.camera)  # fmt: skip
        print(f"wrote {path} (open it in a browser; no server needed)")
        return 0
    import signal
    import time

    def stop(*_):
        raise KeyboardInterrupt

    signal.signal(signal.SIGTERM, stop)
    try:
        with LiveViewer() as live:
            view = SceneView(live.vis, h, overlays, camera=args.camera)
            if markers is not None:
                view.set_markers(markers, marker_set)
            if traj is not None:
                view.animate(traj, speed=args.speed, fps=args.fps)
            else:
                view.show(h.standing_configuration())
            page = live.publish(view, title)
            print(f"viewer at {page} (127.0.0.1 only); Ctrl-C to stop", flush=True)
            print(f"meshcat's own page: {live.url}", flush=True)
            while live.proc.poll() is None:
                time.sleep(0.5)
    except KeyboardInterrupt:  # the server is stopped by LiveViewer's exit
        print("stopped")
    return 0


def _coordinates_run(args):
    """The body (``--model``, default adult_male) and a still run of joint coordinates
    (.mot/.sto, ``--map``), as recorded: not moved onto the floor, so that a trial's markers
    stay where the coordinates were fitted to them."""
    import numpy as np

    from .model import load
    from .motion.coordinates import MAPS, configurations, guess_map, read_map
    from .motion.storage import read_storage
    from .trajectory import Trajectory

    h = load(args.model or "adult_male", ball_joints=args.ball_joints, massless=args.massless,
             feet=tuple(args.feet) if args.feet else None)  # fmt: skip
    table = read_storage(args.target)
    if args.map is None:
        cmap = guess_map(table)
    elif args.map in MAPS:
        cmap = MAPS[args.map]
    elif Path(args.map).suffix.lower() == ".toml":
        cmap = read_map(args.map)
    else:
        raise HumanoidError(f"--map {args.map}: one of {', '.join(MAPS)} or a TOML file")
    t, q, _ = configurations(h, table, cmap, floor=False)
    n = len(t)
    zeros = np.zeros((n, h.nv))
    return h, Trajectory(t, q, zeros, zeros.copy(), {}, np.zeros(n), np.zeros(n),
                         {"model": h.source, "status": "completed"})  # fmt: skip


def run_summary(traj) -> str:
    """Duration, steps, wall time, real-time factor, residual and energy drift of a run."""
    m = traj.metadata
    sim_time = float(traj.t[-1]) if len(traj.t) else 0.0
    wall = m["wall_time"]
    drift = float(traj.energy[-1] - traj.energy[0]) if len(traj.energy) else float("nan")
    scale = max(abs(float(traj.energy[0])), 1.0) if len(traj.energy) else 1.0
    lines = [
        f"scene        {m['scene'].get('name', '?')} ({m['status']})",
        f"simulated    {sim_time:.3f} s in {m['steps']} steps of {m['dt']} s",
        f"wall time    {wall:.2f} s (real-time factor {sim_time / max(wall, 1e-9):.2f})",
        f"residual     {m['max_residual']:.2e} (largest constraint position error, m or rad)",
        f"energy       {_energy_word(m.get('scene', {}))} {drift:+.3e} J "
        f"({drift / scale:+.2e} relative)",
        f"events       {len(m['events'])} contact events, violations {m['violations'] or 'none'}",
    ]
    return "\n".join(lines)


def _energy_word(scene: dict) -> str:
    """ "drift" where the run's scene conserves energy (an error of the integrator), else
    "change" with what takes or gives energy (:meth:`Scene.energy_exchanges`)."""
    from .scene import Scene

    try:
        why = Scene.from_dict(scene).energy_exchanges()
    except HumanoidError:  # a run whose scene no longer reads: say nothing about the cause
        return "change:"
    return f"change ({', '.join(why)}):" if why else "drift"


def summary(h) -> str:
    """A human-readable summary of a loaded :class:`~humanoid.model.Humanoid`."""
    from .dynamics import centre_of_mass

    m = h.model
    q = h.standing_configuration()
    top = h.standing_height()
    com = centre_of_mass(h, q)
    lines = [
        f"model        {h.source}",
        f"ball joints  {h.ball_joints}",
        f"DoF          nq = {m.nq}, nv = {m.nv} (6 free-flyer + {m.nv - 6} joint)",
        f"mass         {h.mass:.4f} kg",
        f"height       {top:.4f} m standing (top of the visual geometry)",
        f"CoM height   {com[2]:.4f} m standing ({com[2] / top:.3f} x height)",
        f"feet         {h.feet[0]}, {h.feet[1]}",
        "contacts     "
        + (
            ", ".join(h.contact_points["left"] + h.contact_points["right"])
            or "none (the feet have no geometry)"
        ),
        "postures     "
        + (
            ", ".join(
                n + (" (reference)" if n == h.reference_posture else "") for n in sorted(h.postures)
            )  # fmt: skip
            or "none (no SRDF)"
        ),
        "",
        f"{'joint':<28} {'type':<28} {'nq':>2} {'nv':>2}  range [deg]",
    ]

    def span(model, iq):
        lo, hi = model.lowerPositionLimit[iq], model.upperPositionLimit[iq]
        if not (math.isfinite(lo) and math.isfinite(hi)) or abs(lo) > 1e6 or abs(hi) > 1e6:
            return "none"
        return f"{math.degrees(lo):7.1f} .. {math.degrees(hi):6.1f}"

    balls = {b.joint_id: b for b in h.fusion.balls} if h.fusion is not None else {}
    for j in range(1, m.njoints):
        jm = m.joints[j]
        row = f"{m.names[j]:<28} {jm.shortname():<28} {jm.nq:>2} {jm.nv:>2}  "
        if j in balls:  # its range: the Euler angles of the hinge triplet it replaces
            lines.append(row + "the angles of its triplet, in order:")
            em = h.fusion.euler_model
            for name, hid in zip(balls[j].hinges, balls[j].hinge_ids, strict=True):
                lines.append(f"  {name:<62}{span(em, em.joints[hid].idx_q)}")
        elif jm.nq == 1:
            lines.append(row + span(m, jm.idx_q))
        else:
            lines.append(row + ("free" if j == 1 else "none"))
    lines += ["", f"{'segment (link)':<28} {'mass [kg]':>10} {'share':>7}"]
    for name, mass in h.body_masses().items():
        lines.append(f"{name:<28} {mass:>10.4f} {mass / h.mass:>7.2%}")
    return "\n".join(lines)
