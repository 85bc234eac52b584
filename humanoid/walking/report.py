"""Walk reports: the gait summary beside typical human values, and a figure.

The figure (matplotlib, written as PNG) has the vertical and horizontal ground reaction forces
of each foot in body weights, the centre-of-mass and ZMP paths over the footprints, and the CoM
tracking error.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from .norms import ADULT, norms

__all__ = [
    "format_gait_table",
    "format_summary",
    "format_trial_table",
    "gait_table",
    "plot_gait_report",
    "plot_trial_report",
    "plot_walk",
    "trial_table",
]

ROWS = (
    # key, label, unit, scale, human value
    ("speed", "speed", "m/s", 1.0, "1.27-1.46 m/s"),
    ("step_length", "step length", "m", 1.0, "0.66-0.79 m"),
    ("cadence", "cadence", "steps/min", 1.0, "100-120 steps/min"),
    ("double_support", "double support", "% of cycle", 100.0, "~20 %"),
    ("peak_vertical_grf", "peak vertical GRF", "BW", 1.0, "1.1-1.2 BW"),
    ("peak_friction", "peak required friction", "", 1.0, "0.17-0.25"),
    ("com_vertical_excursion", "CoM vertical excursion", "cm", 100.0, "4-5 cm"),
    ("com_lateral_excursion", "CoM lateral excursion", "cm", 100.0, "~4 cm"),
    ("com_error_rms", "CoM tracking error RMS", "mm", 1000.0, "-"),
    ("real_time_factor", "real-time factor", "x", 1.0, "-"),
)
HUMAN_SOURCES = (
    "Bohannon 1997; Murray 1964/1970; Perry & Burnfield; Winter; Powers 2002; Cooper 2008"
)


def format_summary(result) -> str:
    """The gait summary and the acceptance checks as text."""
    s = result.summary
    lines = [f"{'':<26} {'this walk':>14}   typical adult"]
    for key, label, unit, scale, human in ROWS:
        value = s.get(key, float("nan")) * scale
        lines.append(f"{label:<26} {value:>10.3g} {unit:<10} {human}")
    lines.append(f"(typical adult values: {HUMAN_SOURCES})")
    lines.append("")
    lines.append(f"{'check':<20} {'measured':>14}  limit")
    for name, c in result.checks.items():
        value = c["value"]
        text = f"{value:.3g}" if isinstance(value, float) else str(value)
        mark = "ok" if c["ok"] else "FAILED"
        lines.append(f"{name:<20} {text:>14}  {c['limit']} {c['unit']}  {mark}".rstrip())
    return "\n".join(lines)


def _title(result) -> str:
    """The figure's title: the gait of a completed walk; how far a failed one got."""
    summary, meta = result.summary, result.trajectory.metadata
    status = meta["status"]
    if status == "completed" and np.isfinite(summary["speed"]):
        return (f"walk: {summary['speed']:.2f} m/s, {summary['step_length']:.2f} m steps, "
                f"{summary['cadence']:.0f} steps/min")  # fmt: skip
    planned = meta["scene"]["duration"]
    reason = meta.get("message", "").split(":")[0]
    return (f"walk {status} after {summary['simulated']:.2f} s of {planned:.2f} s"
            + (f" ({reason})" if reason else ""))  # fmt: skip


def plot_walk(result, path) -> Path:
    """Write the walk figure (PNG) and return its path."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    from matplotlib.patches import Rectangle

    traj, s = result.trajectory, result.series
    meta = traj.metadata
    weight = meta["weight"]
    fig = plt.figure(figsize=(11, 9.5), constrained_layout=True)
    grid = fig.add_gridspec(3, 2, height_ratios=(1.0, 0.8, 1.0))
    t = traj.t
    ax = fig.add_subplot(grid[0, 0])
    for side, color in (("left", "tab:blue"), ("right", "tab:red")):
        if side in traj.forces:
            f = traj.forces[side]
            ax.plot(t, f[:, 2] / weight, color=color, label=f"{side} vertical")
    ax.set(xlabel="time [s]", ylabel="GRF [body weights]", title="vertical ground reaction force")
    ax.legend(loc="upper right")
    ax.grid(alpha=0.3)
    ax = fig.add_subplot(grid[0, 1])
    for side, color in (("left", "tab:blue"), ("right", "tab:red")):
        if side in traj.forces:
            f = traj.forces[side]
            ax.plot(t, f[:, 0] / weight, color=color, label=f"{side} fore-aft")
            ax.plot(t, f[:, 1] / weight, color=color, ls=":", label=f"{side} lateral")
    ax.set(xlabel="time [s]", ylabel="GRF [body weights]", title="horizontal ground reaction force")
    ax.legend(loc="upper right", fontsize=8)
    ax.grid(alpha=0.3)
    ax = fig.add_subplot(grid[1, :])  # the whole width: a walk is long and narrow
    length, width = meta["sole_size"]
    soles = meta.get("initial_soles", {})
    prints = [(side, soles[side][0], soles[side][1]) for side in soles]
    prints += [(side, x, y) for side, x, y, _, _ in meta.get("footsteps", [])]
    for side, x, y in prints:
        color = "tab:blue" if side == "left" else "tab:red"
        ax.add_patch(Rectangle((x - length / 2, y - width / 2), length, width, fc=color, alpha=0.15,
                               ec=color))  # fmt: skip
    ax.plot(s["zmp_ref"][:, 0], s["zmp_ref"][:, 1], color="gray", lw=1, label="ZMP reference")
    ax.plot(s["zmp_x"], s["zmp_y"], color="tab:orange", lw=0.8, label="ZMP (simulated forces)")
    ax.plot(s["com_x"], s["com_y"], color="k", lw=1.5, label="CoM")
    ax.set(xlabel="x [m]", ylabel="y [m]", title="CoM and ZMP over the footprints")
    ax.set_aspect("equal", adjustable="datalim")  # true shape, the panel keeps its size
    ax.legend(loc="upper left", fontsize=8)
    ax.grid(alpha=0.3)
    ax = fig.add_subplot(grid[2, 0])
    err = np.hypot(s["com_x"] - s["com_ref_x"], s["com_y"] - s["com_ref_y"])
    ax.plot(s["t"], 1000 * err, color="k")
    ax.set(xlabel="time [s]", ylabel="|CoM - reference| [mm]", title="CoM tracking error")
    ax.grid(alpha=0.3)
    ax = fig.add_subplot(grid[2, 1])
    ax.semilogy(s["t"], np.maximum(s["consistency"], 1e-16), color="tab:green", lw=0.6)
    ax.set(xlabel="time [s]", ylabel="max |a_plant - a_QP| / max |a_QP|",
           title="plant vs controller accelerations")  # fmt: skip
    ax.grid(alpha=0.3)
    fig.suptitle(_title(result))
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(path, dpi=90)
    plt.close(fig)
    return path


# -- the gait lab's report of a walk on the ground ------------------------------------------

LABELS = {  # each curve's title and unit
    "hip_flexion": ("hip flexion", "deg"),
    "knee_flexion": ("knee flexion", "deg"),
    "ankle_dorsiflexion": ("ankle dorsiflexion", "deg"),
    "hip_extension_moment": ("hip extensor moment", "N m/kg"),
    "knee_extension_moment": ("knee extensor moment", "N m/kg"),
    "ankle_plantarflexion_moment": ("ankle plantarflexor moment", "N m/kg"),
    "hip_power": ("hip power", "W/kg"),
    "knee_power": ("knee power", "W/kg"),
    "ankle_power": ("ankle power", "W/kg"),
    "grf_vertical": ("vertical GRF", "BW"),
    "grf_anterior": ("fore-aft GRF (braking -)", "BW"),
    "pelvis_obliquity": ("pelvic obliquity (own hip up +)", "deg"),
    "pelvis_rotation": ("pelvic rotation (own hip forward +)", "deg"),
    "shoulder_flexion": ("shoulder flexion (arm swing; no norm)", "deg"),
    "pelvis_tilt": ("pelvic tilt (anterior +)", "deg"),
    "hip_adduction": ("hip adduction", "deg"),
    "hip_rotation": ("hip internal rotation", "deg"),
    "hip_abduction_moment": ("hip abductor moment", "N m/kg"),
}
PANELS = tuple(
    (n, *LABELS[n])
    for n in (
        "hip_flexion",
        "knee_flexion",
        "ankle_dorsiflexion",
        "hip_extension_moment",
        "knee_extension_moment",
        "ankle_plantarflexion_moment",
        "hip_power",
        "knee_power",
        "ankle_power",
        "grf_vertical",
        "grf_anterior",
        "pelvis_obliquity",
        "pelvis_rotation",
        "shoulder_flexion",
    )
)
SIDE_COLOURS = {"left": "tab:red", "right": "tab:green"}  # a gait lab's colours
CAPTION = 11  # the report's grid slot (row-major, three a row) that holds the caption


def _adult(key: str, scale: float = 1.0) -> tuple[tuple[float, float], str]:
    """An adult spatiotemporal norm of :data:`~humanoid.walking.norms.ADULT` (in the table's
    units) and its source's short name."""
    (lo, hi), _, source = ADULT[key]
    return (lo * scale, hi * scale), source.split(":")[0]


GAIT_ROWS = (
    # key, label, unit, scale, the adult norm (low, high) or None, its source; "curve": the
    # range of the normative curve of the same name at the walk's speed, +- its mean SD
    ("speed", "speed", "m/s", 1.0, *_adult("speed")),
    ("cadence", "cadence", "steps/min", 1.0, *_adult("cadence")),
    ("step_length", "step length", "m", 1.0, *_adult("step_length")),
    ("double_support", "double support", "% cycle", 100.0, *_adult("double_support", 100.0)),
    ("stance", "stance", "% cycle", 100.0, (58.0, 62.0), "Perry & Burnfield"),
    ("com_vertical", "CoM vertical excursion", "cm", 100.0, (3.0, 5.0), "Gard 2004"),
    ("com_lateral", "CoM lateral sway", "cm", 100.0, (2.0, 5.0), "Perry & Burnfield"),
    ("grf_first_peak", "vertical GRF, 1st peak", "BW", 1.0, (1.05, 1.30), "Winter 2009"),
    ("grf_trough", "vertical GRF, trough", "BW", 1.0, (0.60, 0.85), "Winter 2009"),
    ("grf_second_peak", "vertical GRF, 2nd peak", "BW", 1.0, (1.05, 1.30), "Winter 2009"),
    ("braking", "braking force peak", "BW", 1.0, (0.15, 0.25), "Winter 2009"),
    ("propulsion", "propulsive force peak", "BW", 1.0, (0.15, 0.25), "Winter 2009"),
    ("knee_at_strike", "knee at heel strike", "deg", 1.0, (0.0, 10.0), "Perry & Burnfield"),
    ("knee_loading", "knee loading flexion", "deg", 1.0, (10.0, 25.0), "Perry & Burnfield"),
    ("knee_swing", "knee swing flexion", "deg", 1.0, (55.0, 70.0), "Perry & Burnfield"),
    ("ankle_moment_peak", "ankle moment peak", "N m/kg", 1.0, (1.2, 1.6), "Winter 2009"),
    ("ankle_power_peak", "ankle push-off power", "W/kg", 1.0, (2.5, 4.5), "Winter 2009"),
    (
        "hip_extension_moment_in_band",
        "hip moment in band",
        "% cycle",
        100.0,
        (70.0, 100.0),
        "Schwartz 2008 +- 2 SD",
    ),
    (
        "knee_extension_moment_in_band",
        "knee moment in band",
        "% cycle",
        100.0,
        (70.0, 100.0),
        "Schwartz 2008 +- 2 SD",
    ),
    (
        "ankle_plantarflexion_moment_in_band",
        "ankle moment in band",
        "% cycle",
        100.0,
        (70.0, 100.0),
        "Schwartz 2008 +- 2 SD",
    ),
    ("pelvis_obliquity", "pelvic obliquity range", "deg", 1.0, "curve", "Schwartz 2008"),
    ("pelvis_rotation", "pelvic rotation range", "deg", 1.0, "curve", "Schwartz 2008"),
    (
        "shoulder_flexion",
        "arm swing (shoulder)",
        "deg",
        1.0,
        (20.0, 40.0),
        "a 30 deg arc, Perry & Burnfield",
    ),
    ("arm_leg_correlation", "arm against own hip (r)", "", 1.0, (-1.0, -0.7), "opposite"),
    ("heel_to_toe", "steps heel to toe", "%", 100.0, None, ""),
    ("slip", "largest slide in stance", "mm", 1000.0, (0.0, 2.0), ""),
)


def gait_table(analysis) -> list[tuple[str, str, str, bool | None]]:
    """The report's rows: (label, this walk, the adult norm, whether it is within it)."""
    s = analysis.summary
    rows: list[tuple[str, str, str, bool | None]] = []
    for key, label, unit, scale, norm, source in GAIT_ROWS:
        value = s.get(key, float("nan")) * scale
        text = f"{value:.3g} {unit}".rstrip() if np.isfinite(value) else "-"
        if norm is None or not np.isfinite(value):  # no norm, or no complete cycle to measure
            rows.append((label, text, "", None))
            continue
        if isinstance(norm, str):  # "curve"
            mean, sd = norms().curve(key, analysis.dimensionless_speed)
            norm = (float(np.ptp(mean) - sd.mean()), float(np.ptp(mean) + sd.mean()))
        lo, hi = norm
        ok = bool(lo <= value <= hi)
        band = f"{lo:.3g}{' to ' if lo < 0 else '-'}{hi:.3g} {unit}".rstrip()
        rows.append((label, text, band + (f" ({source})" if source else ""), ok))
    return rows


def format_gait_table(analysis) -> str:
    """The report's table as text."""
    lines = [f"{'':<26} {'this walk':>14}   adult norm"]
    for label, value, norm, ok in gait_table(analysis):
        mark = "  (outside)" if ok is False else ""
        lines.append(f"{label:<26} {value:>14}   {norm}{mark}".rstrip())
    return "\n".join(lines)


def plot_gait_report(analysis, path, title: str | None = None) -> Path:
    """A gait lab's report (PNG): hip, knee and ankle angles, moments and powers and the
    ground reaction forces over 0-100 % of the cycle, left and right, over Schwartz 2008's
    normative band (mean +- 1 SD at the walk's dimensionless speed), and the table of
    spatiotemporal values beside adult norms."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from .gait import CUTOFF

    n = norms()
    fig = plt.figure(figsize=(13, 18), constrained_layout=True)
    grid = fig.add_gridspec(6, 3, height_ratios=(1, 1, 1, 1, 1, 1.4))
    stance = analysis.summary["stance"] * 100.0
    for i, (name, label, unit) in enumerate(PANELS):
        slot = i + (i >= CAPTION)  # the panels flow around the caption's slot
        ax = fig.add_subplot(grid[slot // 3, slot % 3])
        if name in n.units:
            mean, sd = n.curve(name, analysis.dimensionless_speed, pelvis="level")
            ax.fill_between(n.percent, mean - sd, mean + sd, color="0.85", lw=0)
            ax.plot(n.percent, mean, color="0.55", lw=1, ls="--")
        for side, colour in SIDE_COLOURS.items():
            c = analysis.curves[side].get(name, [])
            if len(c):
                ax.plot(analysis.percent, c.mean(axis=0), color=colour, lw=1.6, label=side)
        if np.isfinite(stance):
            ax.axvline(stance, color="0.3", lw=0.8, ls=":")
        ax.axhline(0.0, color="0.5", lw=0.5)
        ax.set(title=label, ylabel=unit, xlim=(0, 100))
        if slot >= 12:  # the bottom row
            ax.set_xlabel("% gait cycle")
        ax.grid(alpha=0.3)
        if i == 0 and ax.get_legend_handles_labels()[0]:
            ax.legend(loc="upper right", fontsize=8)
    ax = fig.add_subplot(grid[CAPTION // 3, CAPTION % 3])
    ax.axis("off")
    tilt = n.mean_tilt(analysis.dimensionless_speed)
    ax.text(0.0, 1.0, "grey: Schwartz et al. 2008, mean +- 1 SD at the same\n"
            "dimensionless speed (J Biomech 41:1639, CC-BY-SA 4.0);\n"
            f"its hip flexion and pelvic tilt less its mean tilt ({tilt:.1f} deg:\n"
            "the lab's pelvis, the iliac spines' plane, tilts forward;\n"
            "the body's stands level). Dotted line: toe off (this\n"
            "walk). Forces, moments and powers low-passed at\n"
            f"{CUTOFF:g} Hz (zero lag). Moments are internal, extensor /\n"
            "plantarflexor positive; powers generated +.",
            va="top", fontsize=8.5)  # fmt: skip
    ax = fig.add_subplot(grid[5, :])
    ax.axis("off")
    rows = gait_table(analysis)
    cells = [[label, value, norm] for label, value, norm, _ in rows]
    table = ax.table(cellText=cells, colLabels=["", "this walk", "adult norm"], loc="upper center",
                     colWidths=(0.25, 0.15, 0.42), cellLoc="left")  # fmt: skip
    table.auto_set_font_size(False)
    table.set_fontsize(8.5)
    table.scale(1.0, 1.15)
    for k, (*_, ok) in enumerate(rows, start=1):
        if ok is False:
            table[k, 1].set_text_props(color="tab:red")
    s = analysis.summary
    name = Path(analysis.source).stem
    fig.suptitle(title or (f"{name}: {s['speed']:.2f} m/s, {s['cadence']:.0f} steps/min, "
                           f"{int(s['cycles'])} cycles analysed"))  # fmt: skip
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(path, dpi=80)
    plt.close(fig)
    return path


# -- the report of a person's own trial (humanoid.walking.trial) ------------------------------

TRIAL_PANELS = tuple(
    (n, *LABELS[n])
    for n in (
        # angles, moments, powers, forces: each row of the figure
        "hip_flexion",
        "knee_flexion",
        "ankle_dorsiflexion",
        "pelvis_tilt",
        "pelvis_obliquity",
        "pelvis_rotation",
        "hip_adduction",
        "hip_rotation",
        "hip_abduction_moment",
        "hip_extension_moment",
        "knee_extension_moment",
        "ankle_plantarflexion_moment",
        "hip_power",
        "knee_power",
        "ankle_power",
        "grf_vertical",
        "grf_anterior",
    )
)
TRIAL_ROWS = (
    # key, label, unit, scale, the adult norm (low, high), its source
    ("speed", "speed", "m/s", 1.0, *_adult("speed")),
    ("cadence", "cadence", "steps/min", 1.0, *_adult("cadence")),
    ("step_length", "step length", "m", 1.0, *_adult("step_length")),
    ("stride_length", "stride length", "m", 1.0, (1.32, 1.58), "Murray 1964/1970: 2 steps"),
    ("stance", "stance", "% cycle", 100.0, (58.0, 62.0), "Perry & Burnfield"),
    ("double_support", "double support", "% cycle", 100.0, *_adult("double_support", 100.0)),
)


def trial_table(analysis) -> list[tuple]:
    """The trial's spatiotemporal rows: (label, left, right, adult norm, left within it, right
    within it), each side's mean over its cycles (``-`` without a cycle; the step length of a
    side ends at its own heel strike)."""
    rows = []
    sides = {s: analysis.side_table(s) for s in ("left", "right")}
    for key, label, unit, scale, (lo, hi), source in TRIAL_ROWS:
        texts, oks = [], []
        for s in ("left", "right"):
            v = sides[s][key]
            value = float(np.mean(v)) * scale if len(v) else float("nan")
            texts.append(f"{value:.3g} {unit}" if np.isfinite(value) else "-")
            oks.append(bool(lo <= value <= hi) if np.isfinite(value) else None)
        rows.append((label, *texts, f"{lo:.3g}-{hi:.3g} {unit} ({source})", *oks))
    return rows


def format_trial_table(analysis) -> str:
    """The trial's spatiotemporal table as text (``*``: outside the adult norm)."""
    lines = [f"{'':<16} {'left':>16} {'right':>16}   adult norm"]
    for label, left, right, norm, ok_l, ok_r in trial_table(analysis):
        left += " *" if ok_l is False else "  "
        right += " *" if ok_r is False else "  "
        lines.append(f"{label:<16} {left:>16} {right:>16}   {norm}")
    counts = ", ".join(f"{len(analysis.cycles[s])} {s}" for s in ("left", "right"))
    lines.append(f"(cycles: {counts}; * outside the adult norm)")
    return "\n".join(lines)


def _trial_table_cells(ax, a) -> None:
    """The spatiotemporal table of a trial's analysis ``a`` on ``ax``: per side beside the
    adult norms, a value outside them in red."""
    rows = trial_table(a)
    cells = [[label, left, right, norm] for label, left, right, norm, *_ in rows]
    table = ax.table(cellText=cells, colLabels=["", "left", "right", "adult norm"],
                     loc="upper center", colWidths=(0.22, 0.17, 0.17, 0.5),
                     cellLoc="left")  # fmt: skip
    table.auto_set_font_size(False)
    table.set_fontsize(8.5)
    table.scale(1.0, 1.3)
    for k, (*_, ok_l, ok_r) in enumerate(rows, start=1):
        for col, ok in ((1, ok_l), (2, ok_r)):
            if ok is False:
                table[k, col].set_text_props(color="tab:red")


def plot_trial_report(trial, path, title: str | None = None) -> Path:
    """A gait lab's report of a person's trial (:class:`~humanoid.walking.trial.Trial`, PNG):
    the angles, moments and powers (and the ground reaction forces, with loads) over 0-100 %
    of the cycle, each side's mean +- 1 SD over its cycles in its colour and its toe off as a
    dotted line, over Schwartz 2008's normative band (mean +- 1 SD at the trial's
    dimensionless speed, grey), and the spatiotemporal table per side beside adult norms."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from .gait import CUTOFF

    a = trial.analysis
    n = norms()
    fig = plt.figure(figsize=(16, 16), constrained_layout=True)
    grid = fig.add_gridspec(5, 4)
    stance = {s: a.side_table(s)["stance"] for s in SIDE_COLOURS}
    missing = {"N m/kg": "no moments", "W/kg": "no moments", "BW": "no loads"}
    slots = [*range(0, 8), *range(8, 12), *range(12, 15), 16, 17]  # 15: the caption
    for (name, label, unit), slot in zip(TRIAL_PANELS, slots, strict=True):
        ax = fig.add_subplot(grid[slot // 4, slot % 4])
        if name in n.units:
            mean, sd = n.curve(name, a.dimensionless_speed, pelvis="level")
            ax.fill_between(n.percent, mean - sd, mean + sd, color="0.85", lw=0)
            ax.plot(n.percent, mean, color="0.55", lw=1, ls="--")
        drawn = False
        for side, colour in SIDE_COLOURS.items():
            c = a.curves[side][name]
            if not len(c):
                continue
            drawn = True
            mean, sd = c.mean(axis=0), c.std(axis=0)
            ax.fill_between(a.percent, mean - sd, mean + sd, color=colour, alpha=0.18, lw=0)
            ax.plot(a.percent, mean, color=colour, lw=1.6, label=f"{side} ({len(c)})")
            if len(stance[side]):
                ax.axvline(100.0 * float(np.mean(stance[side])), color=colour, lw=0.9, ls=":")
        if not drawn and unit in missing:
            ax.text(0.5, 0.5, missing[unit] if unit != "BW" or not trial.forces else
                    "the feet on no plate", transform=ax.transAxes, ha="center",
                    color="0.4")  # fmt: skip
        ax.axhline(0.0, color="0.5", lw=0.5)
        ax.set(title=label, ylabel=unit, xlim=(0, 100))
        if slot >= 12:
            ax.set_xlabel("% gait cycle")
        ax.grid(alpha=0.3)
        if slot == 0 and ax.get_legend_handles_labels()[0]:
            ax.legend(loc="upper right", fontsize=8, title="side (cycles)", title_fontsize=8)
    ax = fig.add_subplot(grid[3, 3])
    ax.axis("off")
    sources = ", ".join(f"{s} {trial.events[s]}" for s in SIDE_COLOURS if s in trial.events)
    ax.text(0.0, 1.0, "grey: Schwartz et al. 2008, mean +- 1 SD at\n"
            f"the same dimensionless speed ({a.dimensionless_speed:.2f}; J Biomech\n"
            "41:1639, CC-BY-SA 4.0); hip flexion and pelvic\n"
            f"tilt less its mean tilt ({n.mean_tilt(a.dimensionless_speed):.1f} deg). "
            "Colours: each\nside's mean +- 1 SD over its cycles; dotted: its\n"
            f"toe off. Events: {sources}.\n"
            f"Forces, moments and powers low-passed at {CUTOFF:g} Hz\n"
            f"(zero lag); moments internal, per kg of {trial.mass:.1f} kg,\n"
            "extensor / plantarflexor / abductor +; powers\ngenerated +.",
            va="top", fontsize=8.5)  # fmt: skip
    ax = fig.add_subplot(grid[4, 2:])
    ax.axis("off")
    _trial_table_cells(ax, a)
    s = a.summary
    speed = f"{s['speed']:.2f} m/s, " if np.isfinite(s["speed"]) else ""
    counts = f"left {len(a.cycles['left'])}, right {len(a.cycles['right'])}"
    fig.suptitle(title or f"{trial.source}: {speed}{int(s['cycles'])} cycles ({counts})")
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(path, dpi=80)
    plt.close(fig)
    return path
