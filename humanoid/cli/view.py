"""``humanoid view``: a model or a run in the browser, live or as one HTML file."""

from __future__ import annotations

import math
from pathlib import Path

from ..errors import UsageError
from .options import BODY_HELP, MARKER_SET_HELP, keypoint_options, load_any, model_options

__all__ = ["add_view", "run_view"]


def add_view(command) -> None:
    """``humanoid view``: a model, a run or joint coordinates shown."""
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
    keypoint_options(v)
    v.add_argument("--model", help=BODY_HELP + " (for .mot/.sto coordinates; default "
                   "adult_male)")  # fmt: skip
    v.add_argument("--map", help="the coordinates' model (gait2392, gait2354, rajagopal, TOML; "
                   "default: told from the file)")  # fmt: skip
    model_options(v)


def run_view(args) -> int:
    from ..viewer import check_playback, export_html

    check_playback(args.speed, args.fps)
    overlays = _overlays(args)
    h, traj = _target(args)
    markers = marker_set = None
    if args.markers:
        if traj is None:
            raise UsageError("--markers are drawn with a motion: a run (.npz) or joint "
                             "coordinates (.mot/.sto)")  # fmt: skip
        from ..motion.commands import marker_set_of, markers_file

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
    return _serve(args, h, traj, overlays, (markers, marker_set), title)


def _overlays(args):
    """The overlays the ``--no-*`` options leave on, the forces' arrows at ``--force-scale``."""
    from ..viewer import Overlays

    if not 0.0 <= args.force_scale < math.inf:
        raise UsageError(f"--force-scale {args.force_scale}: a length per body weight >= 0")
    return Overlays(
        forces=not args.no_forces,
        com=not args.no_com,
        footprints=not args.no_footprints,
        ground=not args.no_ground,
        force_scale=args.force_scale,
        markers=not args.no_markers,
    )


def _target(args):
    """The body and the run (or None) that ``view``'s target names."""
    suffix = Path(args.target).suffix.lower()
    if suffix == ".npz":
        from ..trajectory import Trajectory
        from ..viewer import humanoid_for

        traj = Trajectory.load(args.target)
        return humanoid_for(traj), traj
    if suffix in (".mot", ".sto"):
        return _coordinates_run(args)
    return load_any(args), None


def _serve(args, h, traj, overlays, markers, title: str) -> int:
    """Serve the view live until Ctrl-C (or SIGTERM)."""
    import signal
    import time

    from ..viewer import LiveViewer, SceneView

    def stop(*_):
        raise KeyboardInterrupt

    signal.signal(signal.SIGTERM, stop)
    try:
        with LiveViewer() as live:
            view = SceneView(live.vis, h, overlays, camera=args.camera)
            if markers[0] is not None:
                view.set_markers(*markers)
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

    from ..model import load
    from ..motion.coordinates import MAPS, configurations, guess_map, read_map
    from ..motion.storage import read_storage
    from ..trajectory import Trajectory

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
        raise UsageError(f"--map {args.map}: one of {', '.join(MAPS)} or a TOML file")
    t, q, _ = configurations(h, table, cmap, floor=False)
    n = len(t)
    zeros = np.zeros((n, h.nv))
    return h, Trajectory(t, q, zeros, zeros.copy(), {}, np.zeros(n), np.zeros(n),
                         {"model": h.source, "status": "completed"})  # fmt: skip
