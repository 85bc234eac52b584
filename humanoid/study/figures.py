"""A study's main result as a figure, from its results table and its ``[figure]`` section.

- ``largest``: for each group (``panels`` x ``series`` x ``x``), the largest ``value`` among the
  runs where the column ``where`` is true (the largest push survived); drawn against ``x``, a
  line per ``series``, a panel per ``panels``. A group with no such run is left out.
- ``best``: for each group, the ``value`` at which the column ``of`` is smallest among the
  completed runs (the speed of least cost of transport), against ``x``; beside it, ``of``
  against ``value`` for every group (the curves the minima come from).
"""

from __future__ import annotations

import math
from pathlib import Path

__all__ = ["best_per_group", "largest_per_group", "plot_study"]


def _key(row: dict, name: str | None):
    return row.get(name) if name else None


def _groups(rows, fig) -> dict:
    out: dict = {}
    for r in rows:
        k = (_key(r, fig.get("panels")), _key(r, fig.get("series")), r.get(fig["x"]))
        out.setdefault(k, []).append(r)
    return out


def largest_per_group(rows: list[dict], fig: dict) -> dict:
    """(panel, series, x) -> the largest ``value`` where ``where`` holds (NaN if nowhere)."""
    out = {}
    for k, group in _groups(rows, fig).items():
        ok = [float(r[fig["value"]]) for r in group if r.get(fig["where"])]
        out[k] = max(ok) if ok else math.nan
    return out


def best_per_group(rows: list[dict], fig: dict) -> dict:
    """(panel, series, x) -> (the ``value`` at the smallest ``of``, that smallest ``of``)."""
    out = {}
    for k, group in _groups(rows, fig).items():
        done = [r for r in group if r["status"] == "completed"
                and math.isfinite(float(r.get(fig["of"], math.nan)))]  # fmt: skip
        if done:
            best = min(done, key=lambda r: float(r[fig["of"]]))
            out[k] = (float(best[fig["value"]]), float(best[fig["of"]]))
        else:
            out[k] = (math.nan, math.nan)
    return out


def plot_study(rows: list[dict], fig: dict, path: str | Path, title: str = "") -> Path | None:
    """Draw the figure the study asks for (None if it asks for none or no row has finished)."""
    if fig.get("kind", "none") == "none" or not rows:
        return None
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    path = Path(path)
    panels = sorted({_key(r, fig.get("panels")) for r in rows}, key=str)
    label = fig.get("label", fig["value"])
    if fig["kind"] == "largest":
        data = largest_per_group(rows, fig)
        f, axes = plt.subplots(1, len(panels), figsize=(5.2 * len(panels), 4.2), squeeze=False,
                               sharey=True, constrained_layout=True)  # fmt: skip
        for ax, panel in zip(axes[0], panels, strict=True):
            _lines(ax, data, panel)
            ax.set(xlabel=fig["x"], title=_title(fig.get("panels"), panel))
            ax.set_ylabel(f"largest {label} where {fig['where']}")
    else:
        data = best_per_group(rows, fig)
        f, axes = plt.subplots(1, 2, figsize=(11, 4.2), squeeze=False, constrained_layout=True)
        curves, best = axes[0]
        for (panel, series, x), _ in sorted(data.items(), key=lambda kv: str(kv[0])):
            pts = sorted((float(r[fig["value"]]), float(r[fig["of"]])) for r in rows
                         if (_key(r, fig.get("panels")), _key(r, fig.get("series")),
                             r.get(fig["x"])) == (panel, series, x)
                         and r["status"] == "completed")  # fmt: skip
            if pts:
                xs, ys = zip(*pts, strict=True)
                name = ", ".join(str(v) for v in (panel, series, x) if v is not None)
                curves.plot(xs, ys, "o-", ms=3, label=name)
        curves.set(xlabel=label, ylabel=fig["of"], title=f"{fig['of']} against {label}")
        curves.legend(fontsize=6, ncol=2)
        for panel in panels:
            _lines(best, {k: v[0] for k, v in data.items()}, panel,
                   prefix=_title(fig.get("panels"), panel))  # fmt: skip
        best.set(xlabel=fig["x"], ylabel=f"{label} at the least {fig['of']}",
                 title=f"{label} of least {fig['of']}")  # fmt: skip
    for ax in f.axes:
        ax.grid(alpha=0.3)
    if title or fig.get("title"):
        f.suptitle(fig.get("title", title))
    f.savefig(path, dpi=90)
    plt.close(f)
    return path


def _lines(ax, data: dict, panel, prefix: str = "") -> None:
    series = sorted({k[1] for k in data if k[0] == panel}, key=str)
    for s in series:
        pts = sorted((k[2], v) for k, v in data.items()
                     if k[0] == panel and k[1] == s and not _nan(v))  # fmt: skip
        if pts:
            xs, ys = zip(*pts, strict=True)
            name = " ".join(p for p in (prefix, "" if s is None else str(s)) if p)
            ax.plot(xs, ys, "o-", ms=4, label=name or None)
    if any(line.get_label()[:1] != "_" for line in ax.get_lines()):
        ax.legend(fontsize=7, title=None)


def _nan(v) -> bool:
    return isinstance(v, float) and math.isnan(v)


def _title(name: str | None, value) -> str:
    return f"{name.split('.')[-1]} {value}" if name else ""
