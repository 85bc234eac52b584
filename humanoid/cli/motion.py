"""The motion commands' arguments: ``ik``, ``scale``, ``track``, ``id``, ``loads`` and
``report``; each runs in :mod:`humanoid.motion.commands` (which loads scipy and matplotlib only
when a command runs)."""

from __future__ import annotations

from .options import (
    BODY_HELP,
    MARKER_SET_HELP,
    SCALE_MODES,
    keypoint_options,
    range_option,
    subject_options,
)

__all__ = ["add_id", "add_ik", "add_loads", "add_report", "add_scale", "add_track", "run"]


def add_ik(command) -> None:
    """``humanoid ik``: inverse kinematics of markers, a BVH or keypoints."""
    k = command("ik", help="inverse kinematics of markers (.trc, .c3d), a BVH's joints or "
                "keypoints (.npy/.npz)")  # fmt: skip
    k.add_argument("markers", help="marker trajectories (.trc, .c3d), a BVH motion or keypoints "
                   "(.npy (frames, k, 3), or .npz with 'points' and 'time') [m]")  # fmt: skip
    subject_options(k)
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
    keypoint_options(k, calibration="MARKERS")
    k.add_argument("--map", help="the coordinates' names: rajagopal (default), gait2392, "
                   "gait2354")  # fmt: skip
    k.add_argument("-o", "--output", default="ik.mot", help="coordinates to write (.mot, .csv)")
    k.add_argument("--figure", help="residuals figure (PNG); default: next to the output")
    k.add_argument("--html", help="also write the fitted motion's viewer (one HTML file)")
    k.add_argument("--save-markers", help="write the marker set as used (TOML)")
    k.add_argument("--quiet", action="store_true", help="no progress bar")


def add_scale(command) -> None:
    """``humanoid scale``: a body scaled to a subject's static trial (or walk)."""
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
    range_option(sc, " (over the unscaled body's; written into the scaled URDF)")
    sc.add_argument("-o", "--output", required=True, help="the scaled body (URDF); its marker "
                    "set is written next to it, <name>_markers.toml")  # fmt: skip


def add_track(command) -> None:
    """``humanoid track``: a motion followed in forward simulation."""
    tr = command("track", help="follow a motion in forward simulation by joint torques "
                 "(physics-based tracking)")  # fmt: skip
    tr.add_argument("motion", help="coordinates (.mot/.sto), a run (.npz), or markers (.trc, "
                    ".c3d) and keypoints (.npy, .npz with --layout): fitted first")  # fmt: skip
    subject_options(tr)
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
    keypoint_options(tr, calibration="MOTION")
    tr.add_argument("--marker-set", help=MARKER_SET_HELP)
    tr.add_argument("--register", action="store_true", help="place the technical (cluster) "
                    "markers first, as for ik")  # fmt: skip
    tr.add_argument("--static", help="a static trial to register the technical markers on")
    tr.add_argument("--floor", choices=("auto", "fit", "motion"), default="auto",
                    help="the floor the motion is followed on: fitted to its stances ('fit'), "
                    "the plane of its stances ('motion'), or 'auto' (default): the "
                    "fitted one if it has a treadmill's belt, a tilt over 0.5 deg or a height "
                    "over 5 mm")  # fmt: skip
    tr.add_argument("--reduce", action="store_true", help="reduce the pelvis residuals first "
                    "(small changes to the motion, as OpenSim's RRA; under --loads, or loads "
                    "estimated on the floor)")  # fmt: skip
    tr.add_argument("--cutoff", type=float, help="low-pass cutoff of the reference [Hz] (0: "
                    "none; default: Winter's residual analysis of the motion)")  # fmt: skip
    tr.add_argument("--dt", type=float, help="simulation and control step [s] (default 2 ms)")
    tr.add_argument("--toes", action="store_true", dest="free_toes", help="a body with toes "
                    "tracks with its toe hinges free, rolling over them (default: locked, one "
                    "rigid foot)")  # fmt: skip
    tr.add_argument("-o", "--output", default="tracked.npz", help="the run to write (.npz)")
    tr.add_argument("--mot", help="also write it as OpenSim files (coordinates, ground forces)")
    tr.add_argument("--figure", help="figure (PNG); default: next to the run")
    tr.add_argument("--html", help="also write the viewer (one HTML file)")
    tr.add_argument("--quiet", action="store_true", help="no progress bar")


def add_id(command) -> None:
    """``humanoid id``: inverse dynamics of a motion."""
    d = command("id", help="inverse dynamics of a motion (OpenSim .mot/.sto, or a run .npz)")
    d.add_argument("motion", help="joint coordinates (.mot/.sto, OpenSim's gait models' names) "
                   "or a run (.npz: its own ground forces are the loads)")  # fmt: skip
    subject_options(d)
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
                   "(default: its stances are put on the floor: the median over its frames of "
                   "the lowest sole point)")  # fmt: skip
    d.add_argument(
        "-o", "--output", default="id.sto", help="generalised forces to write (.sto, or .csv)"
    )
    d.add_argument("--figure", help="figure (PNG); default: next to the output")
    d.add_argument("--html", help="also write the motion's viewer, the loads drawn (one HTML "
                   "file)")  # fmt: skip


def add_loads(command) -> None:
    """``humanoid loads``: a C3D's force plates as the feet's loads."""
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


def add_report(command) -> None:
    """``humanoid report``: a gait lab's report of a person's trial."""
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


def run(args) -> int:
    """Run a motion command (``humanoid.motion.commands.run_<command>``)."""
    from ..motion import commands

    return getattr(commands, f"run_{args.command}")(args)
