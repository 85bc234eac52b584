"""Walk reports: the gait summary beside typical human values, and a figure.

The figure (matplotlib, written as PNG) has the vertical and horizontal ground reaction forces
of each foot in body weights, the centre-of-mass and ZMP paths over the footprints, and the CoM
tracking error.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

__all__ = ["format_summary", "plot_walk"]

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
