"""The motion commands of the command line: ``humanoid ik``, ``id``, ``track``, ``loads`` and
``scale`` and ``report`` (and the helpers they share).

Kept out of :mod:`humanoid.cli` so that the parser stays light: this module loads scipy and
matplotlib only when a command runs.
"""

from __future__ import annotations

import time as clock
import zipfile
from pathlib import Path

import numpy as np

from ..errors import HumanoidError, UsageError
from .storage import MotionFileError

__all__ = [
    "markers_file",
    "moments_figure",
    "read_loads_file",
    "read_motion",
    "residual_figure",
    "run_id",
    "run_ik",
    "run_loads",
    "run_report",
    "run_scale",
    "run_track",
    "subject_body",
    "tracking_figure",
]

# the moments drawn and summarised (OpenSim's coordinates; their signs are the map's)
_FLEXION = ("hip_flexion", "knee_angle", "ankle_angle")


def subject_body(args):
    """The body of the command: built from ``--height --mass --sex`` if given, else
    ``--model`` (a URDF, a shipped body, an example-robot-data robot); ``--range`` gives it
    the subject's ranges of motion (one of the toolkit's bodies, rebuilt with them)."""
    from ..anthropometry import BodyParameters, ranges_text
    from ..body import build_urdf
    from ..model import load

    ranges = dict(getattr(args, "ranges", None) or [])
    own = f"; {ranges_text(ranges)}" if ranges else ""
    given = [x is not None for x in (args.height, args.mass, args.sex)]
    if any(given):
        if not all(given):
            raise UsageError("--height, --mass and --sex go together (a person's body)")
        if args.model is not None:
            raise UsageError("give either --model or --height/--mass/--sex, not both")
        params = BodyParameters(args.height, args.mass, args.sex, ranges=ranges)
        return load(build_urdf(params)), f"{args.sex}, {args.height} m, {args.mass} kg{own}"
    name = args.model or "adult_male"
    h = load(name)
    if ranges:
        h = _with_ranges(h, ranges)
    return h, f"{name} ({h.mass:.1f} kg){own}"


def _with_ranges(h, ranges: dict):
    """:func:`~humanoid.motion.scale.with_ranges`, its refusal a usage error."""
    from .scale import ScalingError, with_ranges

    try:
        return with_ranges(h, ranges)
    except ScalingError:
        raise UsageError(f"--range: {h.source} is not one of the toolkit's bodies (humanoid "
                         "build or scale, adult_male, adult_female): give its URDF the "
                         "ranges instead") from None  # fmt: skip


MAX_SPEED = 15.0  # [m/s] a person's walk or run (a treadmill's belt) is slower
MAX_MASS = 500.0  # [kg]
MAX_FORCE = 1e5  # [N] a contact threshold above it is no force plate's


def in_range(option: str, value: float | None, largest: float, unit: str) -> None:
    """Raise UsageError naming ``option`` unless ``value`` is None or a number in
    (0, ``largest``] [``unit``]."""
    if value is not None and not 0.0 < value <= largest:
        raise UsageError(f"{option} {value}: a number in (0, {largest:g}] {unit}")


def _map(args, table=None):
    from .coordinates import MAPS, guess_map, read_map

    if args.map is None:
        return guess_map(table) if table is not None else MAPS["rajagopal"]
    if args.map in MAPS:
        return MAPS[args.map]
    if Path(args.map).suffix.lower() == ".toml":
        return read_map(args.map)
    raise UsageError(f"--map {args.map}: one of {', '.join(MAPS)} or a TOML file of your own")


def _sides(pairs) -> dict | None:
    if not pairs:
        return None
    out = {}
    for text in pairs:
        prefix, sep, side = text.partition("=")
        if not sep or side not in ("left", "right"):
            raise UsageError(f"--loads-side expects PREFIX=left or PREFIX=right, got {text!r}")
        out[prefix] = side
    return out


def read_loads_file(path, sides=None, xml=None) -> list:
    """The loads of a file: an OpenSim external loads ``.mot``/``.sto`` (``sides``: its
    prefixes' feet, ``xml``: its ExternalLoads file; :func:`~humanoid.motion.loads.read_loads`)
    or a C3D (its force plates, given to the feet by its own markers:
    :func:`~humanoid.motion.c3d.c3d_loads`)."""
    from .loads import read_loads

    if Path(path).suffix.lower() == ".c3d":
        if sides or xml:
            raise UsageError(
                f"{path}: --loads-side and --loads-xml name the feet of a .mot's loads; a "
                "C3D's plates are given to the feet by its markers"
            )
        from .c3d import c3d_loads

        loads = c3d_loads(path)[1]
        if not loads:
            raise MotionFileError(f"{path}: no plate contact could be given to a foot")
        return loads
    return read_loads(path, sides, xml)


def read_motion(args):
    """(body, its description, time, q, loads, map, what was left out) of the command's
    motion: a run (.npz: its configurations and its ground forces per foot) or an OpenSim
    coordinate file (.mot/.sto) with optional ``--loads`` (.mot, or a C3D's plates)."""
    import warnings

    from ..anthropometry import ranges_text
    from ..trajectory import Trajectory
    from .coordinates import UnmappedWarning, configurations
    from .loads import Load
    from .storage import read_storage

    path = Path(args.motion)
    if path.suffix.lower() == ".npz":
        run = Trajectory.load(path)
        own = args.model is None and args.height is None  # the body the run was made on
        if own and isinstance(run.metadata.get("body"), dict):
            from ..viewer import humanoid_for

            # as it was loaded (a walk's toes locked)
            h, what = humanoid_for(run), f"{run.metadata.get('model')} (the run's)"
            ranges = dict(getattr(args, "ranges", None) or [])
            if ranges:
                h = _with_ranges(h, ranges)
                what += f"; {ranges_text(ranges)}"
        else:
            if own:
                args.model = run.metadata.get("model")
            h, what = subject_body(args)
        if run.q.shape[1] != h.nq:
            raise UsageError(
                f"{path}: its configurations have {run.q.shape[1]} entries, the body "
                f"{what} {h.nq}: give the body the run was made with (--model)"
            )
        loads = [Load.from_wrench(s, run.t, run.forces[f"ground_{s}"])
                 for s in ("left", "right") if f"ground_{s}" in run.forces]  # fmt: skip
        if args.loads:
            loads += read_loads_file(args.loads, _sides(args.loads_side), args.loads_xml)
        return h, what, run.t, run.q, loads, _map(args), []
    h, what = subject_body(args)
    table = read_storage(path)
    cmap = _map(args, table)
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always", UnmappedWarning)
        t, q, left_out = configurations(h, table, cmap, floor=not args.no_floor)
    del caught  # listed in the summary instead
    sides = _sides(args.loads_side)
    loads = read_loads_file(args.loads, sides, args.loads_xml) if args.loads else []
    return h, what, t, q, loads, cmap, left_out


def _save(fig, path, title: str) -> Path:
    import matplotlib.pyplot as plt

    fig.suptitle(title)
    fig.tight_layout()
    path = Path(path)
    fig.savefig(path, dpi=110)
    plt.close(fig)
    return path


def moments_figure(path, table, mass: float, title: str = "", residual=None) -> Path:
    """Hip, knee and ankle moments (N m/kg, both sides) and the root residuals over time
    (``residual``: (time, force (n, 3), moment (n, 3)) in world axes)."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, axes = plt.subplots(2, 3, figsize=(14, 7), sharex=True)
    for ax, coord in zip(axes.flat[:3], _FLEXION, strict=True):
        for side, colour in (("r", "tab:red"), ("l", "tab:blue")):
            label = f"{coord}_{side}_moment"
            if label in table:
                ax.plot(table.time, table.column(label) / mass, colour,
                        label="right" if side == "r" else "left")  # fmt: skip
        ax.axhline(0.0, color="0.6", lw=0.8)
        ax.set_title(f"{coord}_moment")
        ax.set_ylabel("N m/kg")
        ax.legend(loc="best", fontsize=8)
    weight = mass * 9.81
    if residual is not None:
        t, force, moment = residual
        panels = (("force", "% body weight", force, 100.0 / weight), ("moment", "N m", moment, 1.0))
        for k, (name, unit, data, scale) in enumerate(panels):
            ax = axes[1, k]
            for c, colour in zip("xyz", ("tab:orange", "tab:green", "tab:purple"), strict=True):
                ax.plot(t, data[:, "xyz".index(c)] * scale, colour, label=c)
            ax.axhline(0.0, color="0.6", lw=0.8)
            ax.set_title(f"root residual {name} (world axes)")
            ax.set_ylabel(unit)
            ax.legend(loc="best", fontsize=8)
    for ax in axes[1]:
        ax.set_xlabel("time [s]")
    axes[1, 2].axis("off")
    return _save(fig, path, title)


def _estimated_loads(h, t, q, loads, cutoff, args):
    """``id`` without force plates (or ``--estimate-loads``): the feet's ground forces estimated
    on the floor fitted to the motion; (loads, floor, its line, estimate vs measured rows)."""
    from .floor import fit_floor
    from .inverse_dynamics import derivatives, estimate_loads, lowpass

    compared = []
    floor = None
    start = clock.perf_counter()
    d = derivatives(h.model, t, q, cutoff=cutoff, rate=args.rate, velocity=args.velocity)
    try:  # the floor as it is: the loads are estimated on it
        floor = fit_floor(h, d[0], d[1])
        floor_line = floor.summary()
    except HumanoidError as exc:
        floor_line = f"not fitted ({exc}): the plane of the motion's stances"
    estimated = estimate_loads(h, *d, floor=floor)
    for x in estimated:
        measured = [m for m in loads if m.body == x.body]
        if measured:
            fz = np.interp(x.time, measured[0].time, measured[0].force[:, 2])
            if cutoff is not None:
                fz = lowpass(fz, 1.0 / (x.time[1] - x.time[0]), cutoff)
            compared.append((x.body, float(np.sqrt(np.mean((x.force[:, 2] - fz) ** 2))),
                             float(fz.max()), float(x.force[:, 2].max())))  # fmt: skip
    print(f"estimated    the feet's ground forces in {clock.perf_counter() - start:.2f} s "
          "(no force plates, or --estimate-loads)")  # fmt: skip
    return estimated, floor, floor_line, compared


def _print_id_input(r, h, what, cmap, shown, loads, floor_line, left_out, reduced, compared):
    """``id``'s summary of what went in: the body, motion, loads, floor and their changes."""
    print(f"body         {what}, map {cmap.name}")
    print(f"motion       {len(r.time)} frames at {1.0 / (r.time[1] - r.time[0]):.1f} Hz, "
          f"{r.time[0]:.3f}-{r.time[-1]:.3f} s, "
          f"filter {'none' if shown is None else f'{shown:g} Hz'}")  # fmt: skip
    names = ", ".join(f"{x.body} ({x.name or 'run'})" for x in loads) or "none"
    print(f"loads        {names}")
    if floor_line:
        print(f"floor        {floor_line}")
    if left_out:
        print(f"left out     {', '.join(left_out)} (the body has no joint for them)")
    for line in reduced or []:
        print(f"reduced      {line}")
    weight = h.mass * 9.81
    for side, t0, t1, dx, dy in r.carried:
        print(f"carried      {side} load {t0:.2f}-{t1:.2f} s by ({dx * 1e3:+.0f}, "
              f"{dy * 1e3:+.0f}) mm with the foot")  # fmt: skip
    for side, rms, peak_m, peak_e in compared:
        print(f"estimate vs measured, {side}: vertical force RMS difference "
              f"{rms / weight:.3f} BW (peaks {peak_m / weight:.2f} measured, "
              f"{peak_e / weight:.2f} estimated)")  # fmt: skip


def _print_id_moments(r, table, mass: float) -> None:
    """``id``'s summary of what came out: the flexion moments' peaks and the root residuals."""
    weight = mass * 9.81
    for coord in _FLEXION:
        peaks = []
        for side in "rl":
            label = f"{coord}_{side}_moment"
            if label in table:
                x = table.column(label) / mass
                peaks.append(f"{side} {x.min():+.2f}/{x.max():+.2f}")
        if peaks:
            print(f"{coord + '_moment':26s} N m/kg min/max: {', '.join(peaks)}")
    rf = np.linalg.norm(r.residual_force, axis=1)
    rm = np.linalg.norm(r.residual_moment, axis=1)
    print(f"root residual force   RMS {np.sqrt(np.mean(rf**2)):.1f} N "
          f"({np.sqrt(np.mean(rf**2)) / weight * 100:.1f} % BW), max {rf.max():.1f} N")  # fmt: skip
    print(f"root residual moment  RMS {np.sqrt(np.mean(rm**2)):.1f} N m, max {rm.max():.1f} N m")


def _id_html(args, h, r) -> None:
    """``id --html``: the motion in the viewer with its ground loads."""
    from ..trajectory import Trajectory
    from ..viewer import export_html

    n = len(r.time)
    ground = sum(r.loads.values()) if r.loads else np.zeros((n, 6))
    traj = Trajectory(r.time, r.q, r.v, r.tau, {"ground": np.asarray(ground)}, np.zeros(n),
                      np.zeros(n), {"model": h.source, "status": "completed"})  # fmt: skip
    print(f"viewer       {export_html(h, args.html, traj=traj, title='inverse dynamics')}")


def run_id(args) -> int:
    """``humanoid id``: inverse dynamics of a motion, written as OpenSim names it."""
    import warnings

    from .coordinates import generalized_forces_table
    from .floor import ResidualWarning, residual_check
    from .inverse_dynamics import inverse_dynamics, recorded_feet
    from .storage import write_csv, write_storage

    cutoff = None if args.cutoff is not None and args.cutoff <= 0 else args.cutoff
    shown = cutoff  # the filter the motion went through
    import scipy.signal  # noqa: F401 - imported before the clock starts: the timing is the ID's

    h, what, t, q, loads, cmap, left_out = read_motion(args)
    compared = []
    floor = floor_line = None
    if args.estimate_loads or not loads:
        loads, floor, floor_line, compared = _estimated_loads(h, t, q, loads, cutoff, args)
    feet = None
    if args.markers:  # where the recorded feet were: carry the loads with the body's feet
        chosen, recorded = marker_set_of(h, markers_file(args.markers, args), args.marker_set,
                                         crop=False)  # fmt: skip
        feet = recorded_feet(h, t, q, recorded, chosen.markers)
    reduced = None
    if getattr(args, "reduce", False) or getattr(args, "reduced", None):
        h, t, q, loads, reduced = _reduced(h, t, q, loads, cutoff, args, cmap)
        shown = cutoff
        cutoff, feet = None, None  # (the reduced motion and its loads are filtered)
    start = clock.perf_counter()
    r = inverse_dynamics(h, t, q, loads, cutoff=cutoff, rate=args.rate, velocity=args.velocity,
                         recorded_feet=feet)  # fmt: skip
    elapsed = clock.perf_counter() - start
    table = generalized_forces_table(h, r.time, r.q, r.tau, cmap)
    table.name = "Inverse Dynamics"
    out = Path(args.output)
    written = write_csv(out, table) if out.suffix.lower() == ".csv" else write_storage(out, table)
    figure = Path(args.figure) if args.figure else out.with_suffix(".png")
    moments_figure(figure, table, h.mass, f"{Path(args.motion).name}: {what}",
                   (r.time, r.residual_force, r.residual_moment))  # fmt: skip
    weight = h.mass * 9.81
    n = len(r.time)
    _print_id_input(r, h, what, cmap, shown, loads, floor_line, left_out, reduced, compared)
    _print_id_moments(r, table, h.mass)
    warning = residual_check(r.time, r.residual_force, weight, loads, floor)
    if warning:
        warnings.warn(warning, ResidualWarning, stacklevel=2)
    print(f"time         {elapsed * 1e3:.1f} ms ({elapsed / n * 1e6:.0f} us per frame)")
    print(f"wrote        {written}")
    print(f"figure       {figure}")
    if args.html:
        _id_html(args, h, r)
    return 0


def _reduced(h, t, q, loads, cutoff, args, cmap=None):
    """The motion with its residuals reduced (:func:`~humanoid.motion.reduce.
    reduce_residuals`): (the body with the mass changes, time, q, the loads as applied, the
    summary's lines); ``args.reduced``: the motion written there too."""
    import copy

    from .reduce import reduce_residuals

    start = clock.perf_counter()
    red = reduce_residuals(h, t, q, loads, cutoff=cutoff)
    body = copy.copy(h)
    body.model = red.model
    lines = [*red.summary(), f"in {clock.perf_counter() - start:.1f} s ({red.iterations} "
             "Gauss-Newton iterations)"]  # fmt: skip
    if getattr(args, "reduced", None):
        from .coordinates import coordinates_table
        from .storage import write_storage

        table = coordinates_table(h, red.time, red.q, cmap or "rajagopal")
        table.name = "Coordinates (residuals reduced)"
        lines.append(f"wrote {write_storage(Path(args.reduced), table)}")
    return body, red.time, red.q, red.loads, lines


def _camera_keypoints(args, path):
    """2D keypoints (``path``: a folder of OpenPose JSON folders, one per camera, in
    ``--layout`` at ``--rate``) and the ``--calibration``'s cameras, matched."""
    from .cameras import match_cameras, read_calibration, read_openpose
    from .markers import KEYPOINT_LAYOUTS

    if args.layout is None:
        raise UsageError(f"{path}: 2D keypoints need --layout "
                         f"({', '.join(KEYPOINT_LAYOUTS)})")  # fmt: skip
    if not Path(path).is_dir():
        raise UsageError(f"{path}: with --calibration, the keypoints are a folder of "
                         f"OpenPose .json folders, one per camera")  # fmt: skip
    keypoints = read_openpose(path, args.layout, args.rate or 30.0)
    cameras = read_calibration(args.calibration)
    return keypoints, match_cameras(keypoints, cameras, args.calibration)


def markers_file(path, args):
    """Marker trajectories: a TRC or C3D file, or keypoints (.npy (frames, k, 3) or .npz with
    ``points`` and optional ``time``) in ``--layout`` at ``--rate``."""
    from .markers import KEYPOINT_LAYOUTS, keypoints, read_c3d, read_trc
    from .storage import MAX_RATE

    path = Path(path)
    suffix = path.suffix.lower()
    rate = getattr(args, "rate", None)
    if rate is not None and not 0.0 < rate <= MAX_RATE:
        raise UsageError(f"--rate {rate}: a frame rate in (0, {MAX_RATE:g}] Hz")
    if suffix == ".trc":
        return read_trc(path)
    if suffix == ".c3d":
        return read_c3d(path)
    if suffix == ".bvh":
        from .bvh import read_bvh

        return read_bvh(path)
    if suffix in (".npy", ".npz"):
        if args.layout is None:
            raise UsageError(f"{path}: keypoints need --layout ({', '.join(KEYPOINT_LAYOUTS)})")
        try:
            loaded = np.load(path, allow_pickle=False)
            if suffix == ".npz":
                if "points" not in loaded.files:
                    raise MotionFileError(f"{path}: no 'points' array (frames, k, 3)")
                points = loaded["points"]
                time = loaded["time"] if "time" in loaded.files else None
            else:
                points, time = loaded, None
        except (OSError, ValueError, EOFError, zipfile.BadZipFile) as exc:
            raise MotionFileError(f"cannot read {path}: {exc}") from None
        if time is None:
            time = np.arange(len(points)) / (args.rate or 30.0)
        return keypoints(time, points, args.layout, y_up=args.y_up, source=str(path))
    raise MotionFileError(f"{path}: markers are .trc, .c3d, .bvh, or keypoints in .npy/.npz")


def marker_set_of(h, markers, choice, crop: bool = True):
    """The marker set for a trial's markers (:func:`~humanoid.motion.marker_sets.
    resolve_marker_set`: ``choice`` a shipped set's name, a TOML file, or None: told from the
    labels), printed with what it left out; and the trial's markers (labels without a
    subject's prefix), cropped to the frames where half of them are seen if ``crop``."""
    import warnings

    from .marker_sets import MarkerSetWarning, resolve_marker_set

    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always", MarkerSetWarning)
        chosen = resolve_marker_set(h, markers, choice)
    print(f"marker set   {chosen.describe()}")
    for message in _said(caught, MarkerSetWarning):
        print(f"warning      {message}")
    markers = chosen.trajectories
    if crop:
        markers, before, after = chosen.cropped()
        if before or after:
            print(f"frames       {markers.time[0]:.3f}-{markers.time[-1]:.3f} s, where half the "
                  f"markers are seen ({before} frames before, {after} after left out)")  # fmt: skip
    return chosen, markers


def fit_input(args, path):
    """What ``humanoid ik`` and ``track`` fit from ``path``: its markers (or keypoints and
    their ``cameras``, else None), the body and how it was made, the marker set and whether
    to register it, and ``--static``'s trial (None without; its labels without a subject's
    prefix, as the trial's are)."""
    from .markers import MarkerTrajectories, default_markers, read_markers

    cameras = None
    if getattr(args, "calibration", None):
        markers, cameras = _camera_keypoints(args, path)
    else:
        markers = markers_file(path, args)
    h, what = subject_body(args)
    if cameras:  # (keypoints: their set is the layout's, nothing to register)
        marker_set = read_markers(args.marker_set) if args.marker_set else default_markers(h)
        register = False
    else:
        chosen, markers = marker_set_of(h, markers, args.marker_set)
        marker_set, register = chosen.markers, args.register or chosen.register
    static = markers_file(args.static, args) if args.static else None
    if static is not None:
        from .marker_sets import strip_prefix

        static = MarkerTrajectories(static.time, strip_prefix(static.names)[0],
                                    static.positions, static.source)  # fmt: skip
    return markers, cameras, h, what, marker_set, register, static


def run_ik(args) -> int:
    """``humanoid ik``: inverse kinematics of markers or keypoints, written as coordinates."""
    import sys
    import warnings

    from tqdm import tqdm

    from .coordinates import MAPS, coordinates_table
    from .ik import RangeLimitWarning, UnconstrainedWarning, inverse_kinematics
    from .markers import write_markers
    from .storage import write_csv, write_storage

    if args.map not in (None, *MAPS):
        raise UsageError(f"--map {args.map}: one of {', '.join(MAPS)}")
    markers, cameras, h, what, marker_set, register, static = fit_input(args, args.markers)
    bar = tqdm(total=len(markers.time) * (2 if register and not args.static else 1),
               unit="frame",
               disable=args.quiet or not sys.stderr.isatty())  # fmt: skip
    start = clock.perf_counter()
    try:
        with warnings.catch_warnings():  # (said below, one line each)
            warnings.simplefilter("ignore", RangeLimitWarning)
            warnings.simplefilter("ignore", UnconstrainedWarning)
            r = inverse_kinematics(h, markers, marker_set,
                                   register=register or static is not None, static=static,
                                   smoothing=args.smoothing, cameras=cameras,
                                   ball_ranges=getattr(args, "ball_ranges", False),
                                   progress=lambda i: bar.update(1))  # fmt: skip
    finally:
        bar.close()
    elapsed = clock.perf_counter() - start
    table = coordinates_table(h, r.time, r.q, args.map or "rajagopal")
    out = Path(args.output)
    written = write_csv(out, table) if out.suffix.lower() == ".csv" else write_storage(out, table)
    frame = r.frame_rms()
    print(f"body         {what}")
    print(f"markers      {len(r.names)} of {len(markers.names)} in the set, {len(r.time)} frames"
          f" at {markers.rate:.1f} Hz" + (", registered" if register or args.static else "")
          + (f" on {Path(args.static).name}" if args.static else ""))  # fmt: skip
    if cameras:
        unused = [n for n in markers.names if n not in marker_set]
        if unused:
            print(f"not in set   {', '.join(unused)}")
    print(f"residual     RMS per frame: mean {np.nanmean(frame) * 1e3:.1f} mm, "
          f"max {np.nanmax(frame) * 1e3:.1f} mm"
          + (" (from the cameras' rays)" if cameras else ""))  # fmt: skip
    if cameras:
        assert r.pixels is not None  # a fit to views reports its reprojection
        px = np.sqrt(np.nanmean(r.pixels**2, axis=1))
        print(f"reprojected  {len(cameras)} camera{'s' if len(cameras) > 1 else ''}, RMS per "
              f"frame: mean {np.nanmean(px):.1f} px, max {np.nanmax(px):.1f} px")  # fmt: skip
    if r.depth is not None:
        print(f"depth        {r.depth.summary()}; the feet held on the floor z = 0")
    _print_ik_hidden(r)
    if not r.converged.all():
        print(f"not converged in {int((~r.converged).sum())} frames (their best fit is kept)")
    print(f"time         {elapsed:.2f} s ({elapsed / len(r.time) * 1e3:.1f} ms per frame)")
    print(f"wrote        {written}")
    if args.save_markers:
        assert r.marker_set is not None  # inverse_kinematics sets the set it used
        print(f"marker set   {write_markers(args.save_markers, r.marker_set)}")
    figure = Path(args.figure) if args.figure else out.with_suffix(".png")
    residual_figure(figure, r, f"{Path(args.markers).name}: {what}")
    print(f"figure       {figure}")
    if args.html:
        _ik_html(args, h, r, markers, cameras, marker_set)
    return 0


def _ik_html(args, h, r, markers, cameras, marker_set) -> None:
    """``ik --html``: the fitted motion in the viewer with the markers measured and fitted."""
    import warnings

    from ..trajectory import Trajectory
    from ..viewer import HiddenMarkerWarning, export_html

    n = len(r.time)
    zeros = np.zeros((n, h.nv))
    traj = Trajectory(r.time, r.q, zeros, zeros, {}, np.zeros(n), np.zeros(n),
                      {"model": h.source, "status": "completed"})  # fmt: skip
    if cameras:  # the keypoints as the cameras see them together
        from .cameras import triangulate

        markers = triangulate(markers, cameras)
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always", HiddenMarkerWarning)
        page = export_html(h, args.html, traj=traj, title="inverse kinematics",
                           markers=markers, marker_set=r.marker_set or marker_set)  # fmt: skip
    print(f"viewer       {page} (the markers: measured, fitted, residuals)")
    _print_hidden(caught)


def _said(caught, categories) -> list[str]:
    """The messages of the caught warnings of ``categories`` (a class or a union), to print as
    lines of a command's summary; every other caught warning raised again."""
    import warnings

    out = []
    for w in caught:
        if issubclass(w.category, categories):
            out.append(str(w.message))
        else:
            warnings.warn_explicit(w.message, w.category, w.filename, w.lineno)
    return out


def _print_hidden(caught) -> None:
    """The viewer's :class:`~humanoid.viewer.HiddenMarkerWarning` as a line of the summary
    (other warnings raised again)."""

    from ..viewer import HiddenMarkerWarning

    for message in _said(caught, HiddenMarkerWarning):
        print(f"viewer hides {message}")


def _print_ik_hidden(r, worst: int = 5) -> None:
    """The worst markers (RMS and largest residual), the joints held at their range's bounds
    and the coordinates no marker saw, one line each."""
    rms, top = r.marker_rms(), r.marker_max()
    for i, (n, v) in enumerate(sorted(rms.items(), key=lambda kv: -kv[1])[:worst]):
        head = "worst        " if i == 0 else " " * 13
        print(f"{head}{n:<16} RMS {v * 1e3:5.1f} mm, max {top[n] * 1e3:5.1f} mm")
    for lim in r.at_limit:
        print(f"at limit     {lim.describe(len(r.time))}")
    counts = r.held.sum(axis=0) if r.held is not None else []
    for c, k in zip(r.coordinates, counts, strict=False):
        if k:
            print(f"unseen       {c} in {k} of {len(r.time)} frames, held")


def residual_figure(path, r, title: str = "") -> Path:
    """Each frame's RMS marker residual, and each marker's RMS (the worst 20)."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, (a, b) = plt.subplots(1, 2, figsize=(11, 4.5), gridspec_kw={"width_ratios": [3, 2]})
    a.plot(r.time, r.frame_rms() * 1e3, "k")
    a.set_xlabel("time [s]")
    a.set_ylabel("RMS marker residual [mm]")
    rms = sorted(r.marker_rms().items(), key=lambda kv: -kv[1])[:20]
    b.barh([n for n, _ in rms][::-1], [v * 1e3 for _, v in rms][::-1], color="tab:blue")
    b.set_xlabel("RMS residual [mm]")
    b.tick_params(axis="y", labelsize=7)
    return _save(fig, path, title)


def _tracking_input(args):
    """The motion to track: fitted to a recording (printing the fit's residuals) or read.

    Returns (body, what, time, q, loads, (markers, marker set) of a recording or None)."""
    suffix = Path(args.motion).suffix.lower()
    fitted = suffix in (".trc", ".c3d", ".bvh", ".npy") or (suffix == ".npz" and args.layout)
    if not (fitted or args.calibration):
        h, what, t, q, loads, _, _ = read_motion(args)
        return h, what, t, q, loads, None
    from .ik import inverse_kinematics

    markers, cameras, h, what, marker_set, register, static = fit_input(args, args.motion)
    fit = inverse_kinematics(h, markers, marker_set, static=static, cameras=cameras,
                             register=register or static is not None)  # fmt: skip
    if cameras:  # the keypoints as the cameras see them together
        from .cameras import triangulate

        markers = triangulate(markers, cameras)
    print(f"ik           {len(fit.names)} markers, residual RMS per frame "
          f"{np.nanmean(fit.frame_rms()) * 1e3:.1f} mm")  # fmt: skip
    if fit.pixels is not None:
        print(f"reprojected  RMS {np.sqrt(np.nanmean(fit.pixels**2)):.1f} px")
    if fit.depth is not None:
        print(f"depth        {fit.depth.summary()}")
    return h, what, fit.time, fit.q, [], (markers, fit.marker_set or marker_set)


def _reduced_to_track(h, t, q, loads, floor, args):
    """``track --reduce``: the motion made consistent with its loads (measured, or estimated
    on the floor where they miss stances); (time, q, the lines that say how)."""
    from .inverse_dynamics import derivatives, estimate_loads

    reduced = []
    d = derivatives(h.model, t, q)
    share = _covered(h, d, loads, floor) if loads else 0.0
    if share < 0.95:  # (plates that miss steps: the reduction needs every stance's load)
        if loads:
            reduced.append(f"the loads cover {share * 100:.0f} % of the stances: the "
                           "reduction's are estimated on the floor")  # fmt: skip
        loads = estimate_loads(h, *d, floor=floor)
    _, t, q, _, lines = _reduced(h, t, q, loads, 6.0, args)
    return t, q, reduced + lines


def _print_tracked(res, cutoff, frames: int, labels) -> None:
    """The tracking run's summary: its reference, status, speed, errors and ground forces."""
    from .tracking import LOST_ANGLE, LOST_POSITION, describe_clamped, lost_at

    traj, mass = res.trajectory, res.body.mass
    meta = traj.metadata
    err = res.joint_error
    rms = np.sqrt(np.mean(err[:, 6:] ** 2, axis=0))
    worst = np.argsort(-rms)[:5]
    sim_time = float(traj.t[-1]) if len(traj.t) else 0.0
    if res.toes:
        print(f"toes         the reference's turned onto the floor: "
              f"{describe_clamped(res.toes, frames)}")  # fmt: skip
    print("reference    filter " + ("none" if res.cutoff is None else f"{res.cutoff:g} Hz")
          + (" (Winter's residual analysis)" if cutoff == "auto" else ""))  # fmt: skip
    print(
        f"status       {meta['status']}" + (f": {meta['message']}" if meta.get("message") else "")
    )
    print(f"real time    {sim_time / max(res.wall_time, 1e-9):.2f} x ({res.wall_time:.1f} s of "
          f"wall time for {sim_time:.2f} s)")  # fmt: skip
    print(f"root error   max {np.abs(err[:, :3]).max() * 1e3:.1f} mm, "
          f"{np.degrees(np.abs(err[:, 3:6]).max()):.2f} deg")  # fmt: skip
    lost = lost_at(err)
    if res.completed and lost is not None:
        print(f"lost         the run's pelvis went over {LOST_POSITION * 100:.0f} cm or "
              f"{LOST_ANGLE:.0f} deg from the motion's at t = {traj.t[lost]:.2f} s"
              f" and ended {np.linalg.norm(err[-1, :3]) * 100:.0f} cm from it: read the joints "
              "with that in mind")  # fmt: skip
    print(f"joint error  RMS {np.degrees(np.sqrt(np.mean(err[:, 6:] ** 2))):.2f} deg, max "
          f"{np.degrees(np.abs(err[:, 6:]).max()):.2f} deg; worst: "
          + ", ".join(f"{labels[6 + i]} {np.degrees(rms[i]):.2f}" for i in worst))  # fmt: skip
    for s in ("left", "right"):
        fz = traj.forces.get(f"ground_{s}")
        if fz is not None and len(fz):
            print(f"ground {s:5s} peak vertical force {fz[:, 2].max() / (mass * 9.81):.2f} BW")


def _tracked_html(args, h, traj, recording, t) -> None:
    """``track --html``: the run in the viewer, with the recording's markers if it has them."""
    import warnings

    from ..viewer import HiddenMarkerWarning, export_html

    markers = marker_set = None
    if recording is not None:  # on the run's clock, which starts at 0
        from .markers import MarkerTrajectories

        measured, marker_set = recording
        markers = MarkerTrajectories(measured.time - t[0], measured.names,
                                     measured.positions, measured.source)  # fmt: skip
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always", HiddenMarkerWarning)
        page = export_html(h, args.html, traj=traj, title="tracked motion",
                           markers=markers, marker_set=marker_set)  # fmt: skip
    print(f"viewer       {page}")
    _print_hidden(caught)


def run_track(args) -> int:
    """``humanoid track``: a motion followed in forward simulation, by joint torques."""
    from .inverse_dynamics import joint_labels
    from .tracking import DT, ReferenceRangeWarning, describe_clamped, inside_ranges, track

    h, what, t, q, loads, recording = _tracking_input(args)
    cutoff = "auto" if args.cutoff is None else (None if args.cutoff <= 0 else args.cutoff)
    q, clamped = inside_ranges(h, q)  # (before the reduction: it makes them consistent)
    floor, floor_line = _tracking_floor(h, t, q, getattr(args, "floor", "auto"))
    reduced = []
    if getattr(args, "reduce", False):
        # (measured loads tell the contacts; estimated ones are the motion's: ``loads`` kept)
        t, q, reduced = _reduced_to_track(h, t, q, loads, floor, args)
    import warnings

    with warnings.catch_warnings(record=True) as caught:  # (the reduction's small excursions)
        warnings.simplefilter("always", ReferenceRangeWarning)
        res = track(h, t, q, loads, cutoff=cutoff, dt=args.dt or DT, quiet=args.quiet, floor=floor,
                    toes=getattr(args, "free_toes", False))  # fmt: skip
    again = [m.split(": ", 1)[-1] for m in _said(caught, ReferenceRangeWarning)]
    assert res.body is not None  # track() returns the body it tracked with
    h = res.body  # (its toes locked unless --toes)
    traj = res.trajectory
    path = traj.save(args.output)
    labels = joint_labels(h.model)
    print(f"body         {what}")
    print(f"floor        {floor_line}")
    if clamped:
        print(f"ranges       the motion clamped into the joint ranges: "
              f"{describe_clamped(clamped, len(q))}")  # fmt: skip
    for line in reduced:
        print(f"reduced      {line}")
    for line in again:
        print(f"ranges       clamped again (the reduced motion): {line}")
    _print_tracked(res, cutoff, len(q), labels)
    print(f"saved        {path}")
    if args.mot:
        from .export import write_opensim

        for written in write_opensim(h, traj, args.mot):
            print(f"opensim      {written}")
    figure = Path(args.figure) if args.figure else Path(path).with_suffix(".png")
    tracking_figure(figure, res, labels, h.mass, f"{Path(args.motion).name}: {what}")
    print(f"figure       {figure}")
    if args.html:
        _tracked_html(args, h, traj, recording, t)
    return 0 if res.completed else 3


def _covered(h, d, loads, floor=None) -> float:
    """The share of the motion's stance samples (feet down by the motion, on ``floor``) whose
    foot carries a measured load (its vertical force over 20 N); ``d``: the motion's (time, q,
    v, a)."""
    from ..model import SIDES
    from .inverse_dynamics import contact_schedule

    motion = contact_schedule(h, d[0], d[1], d[2], floor=floor)
    measured = contact_schedule(h, d[0], d[1], d[2], loads, fill=False)
    down = sum(int(motion[s][1].sum()) for s in SIDES)
    held = sum(int((motion[s][1] & measured[s][1]).sum()) for s in SIDES)
    return held / down if down else 1.0


def _tracking_floor(h, t, q, choice: str):
    """(the floor to track on or None, a line saying which): ``choice`` ``"fit"``,
    ``"motion"`` (the plane of the motion's stances) or ``"auto"`` (the fitted one if it has a
    belt, a tilt over 0.5 deg or a height over 5 mm)."""
    from .floor import fit_floor

    if choice == "motion":
        return None, "the plane of the motion's stances (--floor motion)"
    try:
        floor = fit_floor(h, t, q)
    except HumanoidError as exc:
        return None, f"not fitted ({exc}): the plane of the motion's stances"
    off = (floor.speed > 0.0 or max(abs(floor.tilt_x_deg), abs(floor.tilt_y_deg)) > 0.5
           or abs(floor.height) > 0.005)  # fmt: skip
    if choice == "fit" or off:
        return floor, f"{floor.summary()}: followed in its frame"
    return None, f"{floor.summary()}: level, the motion's own kept"


def tracking_figure(path, res, labels, mass: float, title: str = "") -> Path:
    """The tracking error of the root and the worst joints, and the feet's vertical forces."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    traj, err = res.trajectory, res.joint_error
    fig, (a, b) = plt.subplots(2, 1, figsize=(10, 7), sharex=True)
    a.plot(traj.t, np.linalg.norm(err[:, :3], axis=1) * 1e3, "k", label="root position [mm]")
    rms = np.sqrt(np.mean(err[:, 6:] ** 2, axis=0))
    for i in np.argsort(-rms)[:5]:
        a.plot(traj.t, np.degrees(err[:, 6 + i]), label=f"{labels[6 + i]} [deg]")
    a.axhline(0.0, color="0.6", lw=0.8)
    a.set_title("tracking error (reference minus simulated)")
    a.legend(fontsize=8, loc="best")
    for s, colour in (("left", "tab:blue"), ("right", "tab:red")):
        f = traj.forces.get(f"ground_{s}")
        if f is not None:
            b.plot(traj.t, f[:, 2] / (mass * 9.81), colour, label=s)
    b.set_ylabel("vertical ground force [BW]")
    b.set_xlabel("time [s]")
    b.legend(fontsize=8)
    return _save(fig, path, title)


def _plate_sides(pairs) -> dict[int, str] | None:
    if not pairs:
        return None
    out = {}
    for text in pairs:
        plate, sep, side = text.partition("=")
        if not sep or side not in ("left", "right") or not plate.strip().isdigit():
            raise UsageError(f"--plate-side expects PLATE=left or PLATE=right (PLATE: its "
                             f"number, 1 for the first), got {text!r}")  # fmt: skip
        out[int(plate)] = side
    return out


def run_loads(args) -> int:
    """``humanoid loads``: a C3D's force plates as the feet's loads, written as OpenSim's
    external loads (``.mot`` and its ExternalLoads ``.xml``)."""
    import warnings

    from .c3d import PlateWarning, c3d_contacts, contact_loads, read_events
    from .loads import write_loads

    path = Path(args.c3d)
    out = Path(args.output) if args.output else Path(f"{path.stem}_grf.mot")
    sides = _plate_sides(args.plate_side)
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always", PlateWarning)
        plates, contacts = c3d_contacts(path, threshold=args.threshold, sides=sides)
        loads = contact_loads(plates, contacts)
    time = plates[0].time
    rate = f", {1.0 / (time[1] - time[0]):.0f} Hz" if len(time) > 1 else ""
    print(f"plates       {len(plates)} (" + ", ".join(f"{p.name} type {p.type}" for p in plates)
          + f"), {len(time)} samples{rate}, {time[0]:.3f}-{time[-1]:.3f} s")  # fmt: skip
    for p, a, b, side in contacts:
        print(f"{p.name:12s} contact {p.time[a]:.3f}-{p.time[b - 1]:.3f} s above "
              f"{args.threshold:g} N: {side or 'no'} foot")  # fmt: skip
    if not contacts:
        print(f"contacts     none above {args.threshold:g} N")
    for message in _said(caught, PlateWarning):
        print(f"warning      {message}")
    events = read_events(path)
    if events:
        print(f"events       {len(events)}: " + ", ".join(
            " ".join(x for x in (context, label, f"{t:.3f} s") if x)
            for t, context, label in events[:8]
        ) + (" ..." if len(events) > 8 else ""))  # fmt: skip
    if not contacts:
        raise MotionFileError(f"{path}: no plate has a contact above {args.threshold:g} N "
                         "(--threshold)")  # fmt: skip
    if not loads:
        raise MotionFileError(f"{path}: no plate contact could be given to a foot; name them "
                         "(--plate-side 1=left)")  # fmt: skip
    written = write_loads(out, loads, name=f"{path.stem} ground reaction")
    print(f"loads        {', '.join(f'{x.body} ({x.name})' for x in loads)}")
    print(f"wrote        {written} and {written.with_suffix('.xml')}")
    return 0


def segment_groups(names, marker_set) -> dict[str, list[str]]:
    """The markers ``names`` by the segment they are on (their frame without its side)."""
    groups: dict[str, list[str]] = {}
    for n in names:
        frame = marker_set[n].frame.removeprefix("left_").removeprefix("right_")
        groups.setdefault(frame, []).append(n)
    return groups


def group_rms(fit, names) -> float:
    """The RMS residual of a fit's markers ``names`` over every frame [m]."""
    cols = [fit.names.index(n) for n in names if n in fit.names]
    return float(np.sqrt(np.nanmean(fit.residuals[:, cols] ** 2))) if cols else float("nan")


def _scale_mass(args, markers, marker_set) -> tuple[float, str]:
    """``--mass``: a number [kg], or ``auto`` from the C3D's plates (and how it was weighed)."""
    if str(args.mass).lower() != "auto":
        try:
            return float(args.mass), ""
        except ValueError:
            raise UsageError(f"--mass {args.mass}: a mass in kg, or auto (from a C3D's "
                             "force plates)") from None  # fmt: skip
    if Path(args.static).suffix.lower() != ".c3d":
        raise UsageError(f"--mass auto weighs the subject on a C3D's force plates; "
                         f"{Path(args.static).name} is not a C3D: give the mass "
                         "in kg")  # fmt: skip
    from .c3d import read_plates
    from .scale_walk import plate_mass

    pelvis = [n for n in markers.names if n in marker_set and marker_set[n].frame == "pelvis"]
    w = plate_mass(read_plates(args.static), markers, pelvis)
    stances = ", ".join(f"{p} {a:.3f}-{b:.3f} s {m:.1f} kg" for p, a, b, m in w.stances)
    return w.mass, (f"{w.mass:.1f} kg from the plates: the vertical impulse over each single "
                    "stance with the foot all on a plate (the other foot swinging), over g T + "
                    f"the pelvis markers' change of vertical speed: {stances}")  # fmt: skip


def _print_scale_fits(r) -> None:
    """``scale``'s marker residuals: the unscaled, scaled and placed fits, overall and by
    segment, and the markers placing moved furthest."""
    print(f"{'markers':13s}{'RMS':>9s}{'max':>9s}  [mm], the body fitted to the {r.mode} "
          "trial's frames")  # fmt: skip
    for fit in ("unscaled", "scaled", "placed"):
        worst = max(r.fits[fit].marker_rms().items(), key=lambda kv: kv[1])
        print(f"{fit:13s}{r.rms(fit) * 1e3:9.1f}{r.max(fit) * 1e3:9.1f}  worst {worst[0]} "
              f"{worst[1] * 1e3:.1f} mm RMS")  # fmt: skip
    groups = segment_groups(r.fits["placed"].names, r.marker_set)
    print(f"{'by segment':13s}" + "".join(f"{g:>10s}" for g in groups) + "  RMS [mm]")
    for fit in ("unscaled", "scaled", "placed"):
        print(f"{fit:13s}" + "".join(f"{group_rms(r.fits[fit], n) * 1e3:10.1f}"
                                     for n in groups.values()))  # fmt: skip
    if r.moved:
        far = sorted(r.moved.items(), key=lambda kv: -kv[1])[:3]
        print(f"moved        {len(r.moved)} markers placed; furthest "
              + ", ".join(f"{k} {v * 1e3:.1f} mm" for k, v in far))  # fmt: skip


def run_scale(args) -> int:
    """``humanoid scale``: a body scaled to the subject of a static trial, written as a URDF
    with its placed marker set next to it (``<name>_markers.toml``)."""
    import warnings

    from ..anthropometry import CHAIN, ranges_text
    from ..model import load
    from .markers import write_markers
    from .scale import ScaleWarning, scale_body
    from .scale_walk import MOVING

    name = args.model or ("adult_female" if args.sex == "female" else "adult_male")
    h = load(name)
    chosen, static = marker_set_of(h, markers_file(args.static, args), args.marker_set,
                                   crop=False)  # fmt: skip
    marker_set = chosen.markers
    mass, weighed = _scale_mass(args, static, marker_set)
    start = clock.perf_counter()
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always", ScaleWarning)
        r = scale_body(h, static, marker_set, mass, height=args.height, sex=args.sex,
                       time_range=tuple(args.time_range) if args.time_range else None,
                       fit_frames=args.fit_frames, mode=args.mode,
                       ranges=dict(args.ranges))  # fmt: skip
    elapsed = clock.perf_counter() - start
    out = Path(args.output)
    out.write_text(r.urdf, encoding="utf-8")
    markers = write_markers(out.with_name(f"{out.stem}_markers.toml"), r.marker_set)
    p = r.params
    fit = r.fits["placed"]
    print(f"trial        {Path(args.static).name}: {len(fit.time)} of its frames fitted, "
          f"{fit.time[0]:.3f}-{fit.time[-1]:.3f} s, {len(fit.names)} of {len(static.names)} "
          "markers in the set")  # fmt: skip
    if r.mode == "walk":
        print(f"mode         walk (the markers move {r.movement * 1e3:.0f} mm, median; over "
              f"{MOVING * 1e3:.0f} mm is not static): pairs' median distances, a pair across a "
              "joint measured in the unscaled body's fitted poses, the markers placed on the "
              "walk's frames fitted")  # fmt: skip
    else:
        print(f"mode         static (the markers move {r.movement * 1e3:.0f} mm, median): pairs' "
              "mean distances, the markers placed on the mean pose")  # fmt: skip
    if r.joint_centres:
        print(
            "joint centres "
            + ", ".join(f"{v} as {k}" for k, v in r.joint_centres.items())
            + " (the trial's, a pipeline's: they measure, they are not fitted)"
        )
    if weighed:
        print(f"mass         {weighed}")
    told = "" if args.height else " (stature from the markers)"
    print(f"body         {name} ({r.height[0]:.3f} m, {h.mass:.1f} kg) -> {p.height:.3f} m, "
          f"{p.mass:.1f} kg, {p.sex}{told}")  # fmt: skip
    if p.ranges:
        print(f"ranges       {ranges_text(p.ranges)} (the subject's)")
    print(f"{'measurement':13s}{'factor':>8s}  pairs: experimental / unscaled body [mm]")
    for m in r.measured:
        pairs = ", ".join(f"{a}-{b} {e * 1e3:.1f}/{d * 1e3:.1f}" for a, b, e, d, _ in m.pairs)
        print(f"{m.name:13s}{m.factor:8.4f}  {pairs}")
    print(f"{'segment':13s}{'unscaled':>9s}{'scaled':>9s}  [m]")
    for k, (a, b) in r.lengths.items():
        closes = args.height is not None and k in CHAIN
        why = f"  not measured: {'closes the chain' if closes else 'stature scaling'}"
        why = why if k in r.unmeasured else ""
        print(f"{k:13s}{a:9.4f}{b:9.4f}{why}")
    _print_scale_fits(r)
    for message in _said(caught, ScaleWarning):
        print(f"warning      {message}")
    print(f"time         {elapsed:.2f} s")
    print(f"wrote        {out}")
    print(f"marker set   {markers}")
    return 0


def run_report(args) -> int:
    """``humanoid report``: a gait lab's report of a person's trial (:mod:`humanoid.walking.
    trial`): its figure, and its events, cycles and spatiotemporal table printed."""
    import warnings

    from ..walking.report import format_trial_table, plot_trial_report
    from ..walking.trial import TrialWarning, c3d_trial, read_trial
    from .c3d import PlateWarning
    from .marker_sets import MarkerSetWarning

    if args.marker_set and Path(args.trial).suffix.lower() != ".c3d":
        raise UsageError(f"{args.trial}: --marker-set goes with a C3D trial's markers")
    in_range("--speed", args.speed, MAX_SPEED, "m/s")
    in_range("--mass", args.mass, MAX_MASS, "kg")
    in_range("--threshold", args.threshold, MAX_FORCE, "N")
    mass = args.mass
    if args.mass is not None and args.height is None and args.sex is None:
        args.mass = None  # the subject's mass alone: the moments' divisor, on the default body
    h, what = subject_body(args)
    path = Path(args.trial)
    c3d = path.suffix.lower() == ".c3d"
    if c3d and (args.moments or args.loads or args.events):
        raise UsageError(
            f"{path}: a C3D trial is its own markers, plates and events; --moments, --loads "
            "and --events go with a coordinates file"
        )
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always", TrialWarning)
        warnings.simplefilter("always", PlateWarning)
        warnings.simplefilter("always", MarkerSetWarning)
        if c3d:
            trial = c3d_trial(h, path, mass=mass, speed=args.speed,
                              marker_set=args.marker_set)  # fmt: skip
        else:
            cmap = _map(args, None) if args.map is not None else None
            if (
                args.loads
                and Path(args.loads).suffix.lower() == ".c3d"
                and (args.loads_side or args.loads_xml)
            ):
                raise UsageError(f"{args.loads}: --loads-side and --loads-xml name the feet "
                                 "of a .mot's loads; a C3D's plates are given to the feet "
                                 "by its markers")  # fmt: skip
            trial = read_trial(h, path, args.moments, args.loads, args.events, cmap=cmap,
                               mass=mass, speed=args.speed, sides=_sides(args.loads_side),
                               xml=args.loads_xml, floor=not args.no_floor,
                               threshold=args.threshold)  # fmt: skip
    a = trial.analysis
    print(f"body         {what}")
    print(f"trial        {path.name}" + (" (inverse kinematics and dynamics of its markers "
                                         "and plates)" if c3d else ""))  # fmt: skip
    if trial.marker_set:
        print(f"marker set   {trial.marker_set}")
    source = Path(args.moments).name if args.moments else "the C3D's inverse dynamics"
    print("kinetics     " + (f"{source}, per kg of {trial.mass:.1f} kg" if trial.kinetics
                              else "none: kinematics only"
                              + (" (no force plates)" if c3d else " (--moments)")))  # fmt: skip
    if trial.kinetics and mass is None:
        print(f"mass         {trial.mass:.1f} kg, the body's: give the subject's (--mass)")
    print("forces       " + ("the loads' (--loads)" if trial.forces else "none"))
    for s in ("left", "right"):
        ev = a.events[s]
        cycles = ", ".join(f"{t0:.3f}-{t1:.3f}" for t0, t1 in a.cycles[s]) or "none"
        print(f"{s:<12} events from {trial.events.get(s, 'nothing')}: "
              f"{len(ev['strike'])} strikes, {len(ev['off'])} offs; cycles {cycles} s")  # fmt: skip
    for message in _said(caught, TrialWarning | PlateWarning | MarkerSetWarning):
        print(f"warning      {message}")
    print(format_trial_table(a))
    print(f"report       {plot_trial_report(trial, args.output)}")
    return 0
