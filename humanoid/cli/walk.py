"""``humanoid walk``: a body walked in forward simulation (``--gait person``, ``human`` or
``welded``), its options checked together before any work."""

from __future__ import annotations

import math
import sys
from pathlib import Path

from ..errors import UsageError
from ..variants import INTEGRATORS
from .options import BODY_HELP, load_any, model_options

__all__ = ["GAITS", "add_walk", "run_walk"]

GAITS = ("person", "human", "welded")  # humanoid walk --gait


def add_walk(command) -> None:
    """``humanoid walk``: its options, in the order its help lists them."""
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
    _add_gait_options(w)
    _add_welded_options(w)
    _add_ground_options(w)
    model_options(w, ball_joints=False)


def _add_gait_options(w) -> None:
    """The gait, and the path it walks (from standing, along a circle)."""
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


def _add_welded_options(w) -> None:
    """The options of the welded walk (the QP's plant), and the step."""
    w.add_argument("--integrator", choices=list(INTEGRATORS),
                   help="(--gait welded) the plant's integrator (humanoid variants; default "
                   "semi_implicit_euler)")  # fmt: skip
    w.add_argument("--dt", type=float, default=1e-3, help="simulation and control step [s]")
    w.add_argument("--control-dt", type=float,
                   help="(--gait welded, person) the QP's period [s], a multiple of --dt "
                   "(default: welded 8 ms, the contact forces held between its ticks; person "
                   "4 ms, and at once when a foot lands, lifts or slides)")  # fmt: skip
    w.add_argument(
        "--drop", type=float, help="(--gait welded) pelvis lowered before walking [m] (0.04)"
    )


def _add_ground_options(w) -> None:
    """The options of a walk on the rigid ground: pushes, OpenSim files, the record rate."""
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


# option: (whether 0 is allowed, upper bound)
RANGES = {"--speed": (False, 3.0), "--step-length": (False, 1.0), "--mu": (True, 10.0),
          "--dt": (False, 0.01), "--drop": (False, 0.2)}  # fmt: skip


def run_walk(args) -> int:
    """``humanoid walk``: the options checked, then the gait's walk."""
    from ..walking.plan import MAX_STEPS

    values = {"--speed": args.speed, "--step-length": args.step_length, "--mu": args.mu,
              "--dt": args.dt, "--drop": args.drop}  # fmt: skip
    for option, value in values.items():
        zero, hi = RANGES[option]
        if value is None:
            continue
        above = value >= 0 if zero else value > 0
        if not (math.isfinite(value) and above and value <= hi):
            raise UsageError(f"{option} must be in {'[' if zero else '('}0, {hi:g}], got {value}")
    if args.step_length is not None and args.speed is not None:
        raise UsageError("give --speed or --step-length, not both")
    if not 2 <= args.steps <= MAX_STEPS:
        raise UsageError(f"--steps must be in [2, {MAX_STEPS}], got {args.steps}")
    if args.gait != "welded":
        return _walk_on_ground(args)
    return _welded_walk(args)


def _welded_walk(args) -> int:
    """``humanoid walk --gait welded``: flat feet welded at each step, any humanoid."""
    from ..walking import GaitParameters, format_summary, plot_walk, walk

    given = [o for o, v in (("--report", args.report), ("--push", args.push),
                            ("--largest-push", args.largest_push), ("--mot", args.mot),
                            ("--record-rate", args.record_rate != 100.0)) if v]  # fmt: skip
    if given:
        raise UsageError(f"{', '.join(given)}: only with --gait person or human")
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
        from ..viewer import export_html

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


def _ground_pushes(args) -> list[tuple[str, float]]:
    """The options of ``humanoid walk --gait person|human`` checked, and its ``--push`` es as
    (direction, fraction of body weight)."""
    from ..walking.gait import DIRECTIONS
    from ..walking.walkers import FROM_STANDING_STEPS, MAX_PUSH, PUSHED_STEPS

    given = [o for o, v in (("--step-length", args.step_length), ("--figure", args.figure),
                            ("--drop", args.drop), ("--integrator", args.integrator))
             if v is not None]  # fmt: skip
    if given:
        raise UsageError(f"{', '.join(given)}: only with --gait welded")
    if args.control_dt is not None and args.gait != "person":
        raise UsageError("--control-dt: only with --gait welded or person")
    pushes = []
    for spec in args.push:
        direction, _, fraction = spec.partition(":")
        try:
            value = float(fraction)
        except ValueError:
            value = math.nan
        if direction not in DIRECTIONS or not 0.0 < value <= MAX_PUSH:
            raise UsageError(
                f"--push {spec!r}: give DIRECTION:FRACTION, DIRECTION one of "
                f"{', '.join(DIRECTIONS)}, FRACTION of body weight in (0, {MAX_PUSH:g}]"
            )
        pushes.append((direction, value))
    if args.largest_push and (args.radius is not None or args.from_standing):
        raise UsageError("--largest-push: a straight walk's; not with --radius or "
                         "--from-standing")  # fmt: skip
    if pushes and args.radius is not None:
        raise UsageError("--push: a push is along the room's axes; not with --radius")
    if pushes and args.steps < PUSHED_STEPS:
        raise UsageError(f"--push acts in the third stride: give --steps {PUSHED_STEPS} or "
                         f"more, not {args.steps}")  # fmt: skip
    least = FROM_STANDING_STEPS[args.gait]
    if args.from_standing and (pushes or args.steps < least or args.radius is not None):
        raise UsageError(
            f"--from-standing: give --steps {least} or more, and no --push or --radius"
        )
    if not (math.isfinite(args.record_rate) and 0.0 < args.record_rate * args.dt <= 1.0 + 1e-9):
        raise UsageError(
            f"--record-rate must be positive and at most 1/dt = {1.0 / args.dt:g} Hz, got "
            f"{args.record_rate:g}"
        )
    return pushes


def _walk_on_ground(args) -> int:
    """``humanoid walk --gait person|human``: a person's walk on the rigid ground."""
    from ..walking.gait import analyse, pelvis_push
    from ..walking.report import format_gait_table, plot_gait_report
    from ..walking.walkers import ground_walker

    pushes = _ground_pushes(args)
    h = load_any(args, ball_joints="quaternion")
    cycle, walker = ground_walker(h, args.gait, args.speed, dt=args.dt, mu=args.mu,
                                  quiet=args.quiet, control_dt=args.control_dt)  # fmt: skip
    if args.largest_push:
        return _largest_push(args, h, cycle, walker)
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
        from ..motion.export import write_opensim

        for written in write_opensim(h, walk.trajectory, args.mot):
            print(f"opensim      {written}")
    if args.report:
        print(f"report       {plot_gait_report(analysis, args.report)}")
    if args.html:
        from ..viewer import export_html

        page = export_html(h, args.html, traj=walk.trajectory, title="walk")
        print(f"viewer       {page}")
    if not walk.completed:
        _why_it_fell(args, cycle, pushes)
    return 0 if walk.completed else 3


def _largest_push(args, h, cycle, walker) -> int:
    """``--largest-push``: the largest push the walk survives, each try printed."""
    from ..walking.gait import largest_push

    def tried(fraction, survived):
        print(f"push {fraction:.3f} BW {args.largest_push:8s} "
              f"{'survived' if survived else 'fell'}", flush=True)  # fmt: skip

    found = largest_push(h, args.largest_push, cycle, walk=walker, progress=tried)
    fell = f"{found.fell:.3f} BW" if found.fell is not None else "none tried fell"
    print(f"largest push survived  {found.survived:.3f} BW {found.direction} "
          f"(0.1 s at mid-stance; smallest fall: {fell})")  # fmt: skip
    return 0


def _why_it_fell(args, cycle, pushes) -> None:
    """What to try after a walk on the ground that did not complete (on stderr)."""
    speed = cycle.speed if args.gait == "person" else cycle.gait["speed"]
    if args.from_standing and args.gait == "human":
        print(f"humanoid walk: it did not stop standing from {speed:.2f} m/s; "
              "it stops from 0.8 m/s (--speed 0.8), not yet from a person's free speed; "
              "--gait person starts and stops at it", file=sys.stderr)  # fmt: skip
    elif args.speed is None and not pushes:
        print(f"humanoid walk: it fell at its free speed ({speed:.2f} m/s, a "
              "person's for its leg length); a robot may walk slower: try --speed 0.6",
              file=sys.stderr)  # fmt: skip


def _on_ground_only(args) -> None:
    given = [o for o, v in (("--from-standing", args.from_standing),
                            ("--radius", args.radius is not None)) if v]  # fmt: skip
    if given:
        raise UsageError(f"{', '.join(given)}: only with --gait person or human")
