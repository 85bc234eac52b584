"""A study's main result as a figure, from its results table and its ``[figure]`` section.

- ``threshold``: for each group (``panels`` x ``series`` x ``x``), the largest ``value`` up to
  which the column ``where`` is true in every run of the group (the largest push survived
  with no fall at any smaller one), drawn against ``x``, a line per ``series``, a panel per
  ``panels``; runs above it where ``where`` holds again (a rocking body can survive a larger
  push that a smaller one topples) are drawn as open markers. A group whose smallest value
  already fails is left out.
- ``line``: for each group, the mean ``value`` of its completed runs against ``x`` (a line per
  ``series``, a panel per ``panels``), and the mean of a ``reference`` column dashed (the
  speed a walk was fitted for beside the speed it walked).
- ``best``: for each group, the ``value`` at which the column ``of`` is smallest among the
  completed runs (the speed of least cost of transport), against ``x``; beside it, ``of``
  against ``value`` for every group (the curves the minima come from).
"""

from __future__ import annotations

import math
from pathlib import Path

__all__ = ["best_per_group", "mean_per_group", "plot_study", "result_table",
           "threshold_per_group"]  # fmt: skip


def _key(row: dict, name: str | None):
    return row.get(name) if name else None


def _groups(rows, fig) -> dict:
    out: dict = {}
    for r in rows:
        k = (_key(r, fig.get("panels")), _key(r, fig.get("series")), r.get(fig["x"]))
        out.setdefault(k, []).append(r)
    return out


def threshold_per_group(rows: list[dict], fig: dict) -> dict:
    """(panel, series, x) -> (threshold, islands): the largest ``value`` up to which ``where``
    holds in every run of the group (NaN if it fails at the smallest), and the larger values
    where it holds again."""
    out = {}
    for k, group in _groups(rows, fig).items():
        ordered = sorted((float(r[fig["value"]]), bool(r.get(fig["where"]))) for r in group)
        threshold, failed, islands = math.nan, False, []
        for value, ok in ordered:
            if not ok:
                failed = True
            elif failed:
                islands.append(value)
            else:
                threshold = value
        out[k] = (threshold, islands)
    return out


def mean_per_group(rows: list[dict], fig: dict, column: str | None = None) -> dict:
    """(panel, series, x) -> the mean of ``column`` (default ``value``) over the group's
    completed runs (NaN if none completed)."""
    column = column or fig["value"]
    out = {}
    for k, group in _groups(rows, fig).items():
        vals = [float(r[column]) for r in group if r["status"] == "completed"]
        out[k] = sum(vals) / len(vals) if vals else math.nan
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


def result_table(rows: list[dict], fig: dict) -> str:
    """The figure's numbers as a Markdown table: a row per ``x``, a column per panel and
    series (``threshold``: the threshold; ``line``: the mean, and the means of the columns
    ``also`` names; ``best``: the value at the least ``of``)."""
    if fig.get("kind", "none") == "none" or not rows:
        return ""
    if fig["kind"] == "threshold":
        tables = {"": {k: v[0] for k, v in threshold_per_group(rows, fig).items()}}
    elif fig["kind"] == "line":
        tables = {c: mean_per_group(rows, fig, c) for c in [fig["value"], *fig.get("also", [])]}
        if len(tables) == 1:
            tables = {"": tables[fig["value"]]}
    else:
        tables = {"": {k: v[0] for k, v in best_per_group(rows, fig).items()}}
    first = next(iter(tables.values()))
    groups = sorted({(k[0], k[1]) for k in first}, key=str)
    xs = sorted({k[2] for k in first}, key=lambda v: (str(type(v)), v))
    columns = [(name, g) for name in tables for g in groups]
    names = [" ".join(str(v) for v in (name or None, *g) if v is not None) or fig["value"]
             for name, g in columns]  # fmt: skip
    head = [fig["x"], *names]
    lines = ["| " + " | ".join(head) + " |", "|" + "---|" * len(head)]
    for x in xs:
        cells = [tables[name].get((g[0], g[1], x), math.nan) for name, g in columns]
        lines.append("| " + " | ".join([str(x), *(f"{v:.4g}" for v in cells)]) + " |")
    return "\n".join(lines)


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
    if fig["kind"] == "threshold":
        found = threshold_per_group(rows, fig)
        f, axes = plt.subplots(1, len(panels), figsize=(5.2 * len(panels), 4.2), squeeze=False,
                               sharey=True, constrained_layout=True)  # fmt: skip
        for ax, panel in zip(axes[0], panels, strict=True):
            lines = _lines(
                ax,
                {k: v[0] for k, v in found.items()},
                panel,
                title=(fig.get("series") or "").split(".")[-1] or None,
            )
            for (p, series, x), (_, islands) in found.items():
                if p == panel and islands and series in lines:
                    ax.plot([x] * len(islands), islands, "o", mfc="none", ms=5,
                            color=lines[series].get_color())  # fmt: skip
            ax.set(xlabel=fig["x"], title=_title(fig.get("panels"), panel))
            ax.set_ylabel(f"largest {label} with {fig['where']} at every smaller one")
    elif fig["kind"] == "line":
        data = mean_per_group(rows, fig)
        ref = mean_per_group(rows, fig, fig["reference"]) if fig.get("reference") else {}
        f, axes = plt.subplots(1, len(panels), figsize=(max(6.5, 5.2 * len(panels)), 4.2),
                               squeeze=False,
                               sharey=True, constrained_layout=True)  # fmt: skip
        for ax, panel in zip(axes[0], panels, strict=True):
            lines = _lines(ax, data, panel)
            for series, line in lines.items():
                pts = sorted((k[2], v) for k, v in ref.items()
                             if k[0] == panel and k[1] == series and not _nan(v))  # fmt: skip
                if pts:
                    xs, ys = zip(*pts, strict=True)
                    ax.plot(xs, ys, "--", color=line.get_color(), lw=1,
                            label=f"{fig['reference']} {series or ''}".strip())  # fmt: skip
            if ref:
                ax.legend(fontsize=7)
            ax.set(xlabel=fig["x"], ylabel=label, title=_title(fig.get("panels"), panel))
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
        f.suptitle(fig.get("title", title), fontsize=11)
    f.savefig(path, dpi=90)
    plt.close(f)
    return path


def _lines(ax, data: dict, panel, prefix: str = "", title: str | None = None) -> dict:
    """A line per series of a panel's (x, value) points; returns series -> line."""
    out = {}
    for s in sorted({k[1] for k in data if k[0] == panel}, key=str):
        pts = sorted((k[2], v) for k, v in data.items()
                     if k[0] == panel and k[1] == s and not _nan(v))  # fmt: skip
        if pts:
            xs, ys = zip(*pts, strict=True)
            name = " ".join(p for p in (prefix, "" if s is None else str(s)) if p)
            (out[s],) = ax.plot(xs, ys, "o-", ms=4, label=name or None)
    if any(line.get_label()[:1] != "_" for line in ax.get_lines()):
        ax.legend(fontsize=7, title=title, title_fontsize=7)
    return out


def _nan(v) -> bool:
    return isinstance(v, float) and math.isnan(v)


def _title(name: str | None, value) -> str:
    return f"{name.split('.')[-1]} {value}" if name else ""
