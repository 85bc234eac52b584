"""The model commands: ``build`` (a person's URDF), ``info`` (a model's summary), ``export``
(MJCF) and ``variants`` (the registries' names)."""

from __future__ import annotations

import argparse
import math

from ..variants import REGISTRIES
from .options import BODY_HELP, load_any, model_options, range_option, segment_length

__all__ = [
    "add_build",
    "add_export",
    "add_info",
    "add_variants",
    "run_build",
    "run_export",
    "run_info",
    "run_variants",
    "summary",
]


def add_build(command) -> None:
    """``humanoid build``: the URDF of a person."""
    b = command("build", help="write the URDF body of a person (de Leva 1996)")
    b.add_argument("--height", type=float, required=True, help="stature [m], 0.5-2.5")
    b.add_argument("--mass", type=float, required=True, help="body mass [kg], 10-300")
    b.add_argument("--sex", choices=("male", "female"), required=True)
    b.add_argument(
        "--segment",
        type=segment_length,
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
    range_option(b)
    b.add_argument("-o", "--output", required=True, help="URDF file to write")


def add_info(command) -> None:
    """``humanoid info``: a model's summary."""
    i = command("info", help="summarise a model: DoF, joints, segments, mass, CoM, feet")
    i.add_argument("model", help=BODY_HELP)
    model_options(i)


def add_export(command) -> None:
    """``humanoid export``: a model as MuJoCo's MJCF."""
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
    model_options(x)


def add_variants(command) -> None:
    """``humanoid variants``: the registries' names."""
    command("variants", help="list the integrators, formulations, backends, contact kinds... "
            "that scenes and options accept")  # fmt: skip


def run_build(args) -> int:
    from ..anthropometry import BodyParameters, ranges_text
    from ..body import write_urdf

    params = BodyParameters(args.height, args.mass, args.sex, dict(args.segment), args.toes,
                            dict(args.ranges))  # fmt: skip
    path = write_urdf(params, args.output)
    toes = ", toes" if params.toes else ""
    own = f"; {ranges_text(params.ranges)}" if params.ranges else ""
    print(f"wrote {path} ({params.sex}, {params.height} m, {params.mass} kg{toes}{own})")
    return 0


def run_info(args) -> int:
    print(summary(load_any(args)))
    return 0


def run_export(args) -> int:
    from ..export import write_mjcf

    h = load_any(args)
    path = write_mjcf(h, args.mjcf, mu=None if args.no_floor else args.mu, timestep=args.dt)
    floor = "no floor" if args.no_floor else f"a floor (friction {args.mu:g})"
    print(
        f"wrote {path}: {h.model.nv - 6} joint degrees of freedom, each with a motor; "
        f"joint ranges on; {floor}; MuJoCo's semi-implicit Euler at {args.dt:g} s"
    )
    return 0


def run_variants(args) -> int:
    for registry in REGISTRIES:
        where = f" (scene key {registry.key})" if registry.key else ""
        print(f"{registry.what}{where}")
        width = max(map(len, registry))
        for name, description in registry.items():
            print(f"  {name:<{width}}  {description}")
    return 0


def summary(h) -> str:
    """A human-readable summary of a loaded :class:`~humanoid.model.Humanoid`."""
    from ..dynamics import centre_of_mass

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
