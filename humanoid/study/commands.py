"""``humanoid sweep``: run a study file (or a shipped study by name) and draw its figure."""

from __future__ import annotations

import os
from pathlib import Path

from ..errors import StudyError

__all__ = ["add_sweep_parser", "run_sweep"]


def add_sweep_parser(command) -> None:
    s = command("sweep", help="run a study: many runs on Dask, one Parquet row each, resumable")
    s.add_argument("study", help="a study file (TOML), or a shipped study: push_standing, "
                   "walk_speed, push_slice")  # fmt: skip
    s.add_argument("-o", "--output", help="the study's folder (None: results/studies/NAME)")
    s.add_argument("--scheduler", metavar="ADDRESS",
                   help="an existing Dask scheduler (tcp://host:8786) instead of a local "
                   "cluster; its workers need humanoid installed")  # fmt: skip
    s.add_argument("--workers", type=int, help="local worker processes (None: one per core)")
    s.add_argument("--serial", action="store_true",
                   help="run in this process, one run after another (no Dask)")  # fmt: skip
    s.add_argument("--retry-failed", action="store_true",
                   help="run again the runs whose rows say failed or error")  # fmt: skip
    s.add_argument("--fresh", action="store_true",
                   help="discard the folder's results and start over")  # fmt: skip
    s.add_argument("--list", action="store_true",
                   help="list the runs and what each costs so far; run nothing")  # fmt: skip
    s.add_argument("--quiet", action="store_true", help="no progress bar")


def resolve(name: str) -> Path:
    from ..data import study_names, study_path

    p = Path(name)
    if p.is_file():
        return p
    shipped = study_path(name)
    if shipped is not None:
        return shipped
    raise StudyError(f"no study file {name} (shipped studies: {', '.join(study_names())})")


def run_sweep(args) -> int:
    from .figures import plot_study
    from .spec import load_study
    from .store import read_table
    from .sweep import default_folder, run_study

    study = load_study(resolve(args.study))
    folder = Path(args.output) if args.output else default_folder(study)
    runs = study.runs()
    if args.list:
        done = {r["run"]: r for r in read_table(folder)}
        for run in runs:
            r = done.get(run.id)
            state = f"{r['status']:<10} {r['wall_time']:7.2f} s" if r else "pending"
            params = ", ".join(f"{k}={v}" for k, v in run.params.items())
            print(f"{run.index:5d} {run.id} {state:<20} {params}")
        return 0
    if args.workers is not None and args.workers < 1:
        raise StudyError(f"--workers must be at least 1, got {args.workers}")
    print(f"study {study.name}: {len(runs)} runs ({study.source}) -> {folder}", flush=True)
    result = run_study(study, folder, scheduler=args.scheduler, workers=args.workers,
                       serial=args.serial, retry_failed=args.retry_failed, fresh=args.fresh,
                       quiet=args.quiet)  # fmt: skip
    counts = ", ".join(f"{n} {s}" for s, n in sorted(result.statuses.items()))
    print(f"runs         {result.total}: {counts}")
    print(f"this time    {result.ran} ran, {result.skipped} were already done")
    if result.ran:
        print(f"wall time    {result.wall:.1f} s; the runs' own time {result.run_time:.1f} s "
              f"({result.speedup:.2f} x on {result.workers} worker(s))")  # fmt: skip
    print(f"table        {result.table}")
    if result.interrupted:
        print("interrupted: the rows so far are saved; the same command finishes the rest")
        return 3
    rows = read_table(result.table)
    figure = plot_study(rows, study.figure, folder / "figure.png")
    report = summary(study, rows, result)
    (folder / "result.md").write_text(report)
    if figure is not None:
        print(f"figure       {figure}")
    print(f"result       {folder / 'result.md'}\n\n{report}", end="")
    return 0


def summary(study, rows: list[dict], result) -> str:
    """The study's result in Markdown: its runs by status, what a run costs, and the figure's
    numbers as a table."""
    import statistics

    from ..provenance import machine
    from .figures import result_table

    counts = ", ".join(f"{n} {s}" for s, n in sorted(result.statuses.items()))
    walls = [float(r["wall_time"]) for r in rows if r.get("wall_time")] or [0.0]
    text = [f"`humanoid sweep {study.name}`: {len(rows)} runs ({counts}); a run takes "
            f"{statistics.mean(walls):.2f} s on average (median {statistics.median(walls):.2f} "
            f"s, the longest {max(walls):.1f} s) of one worker's time; {machine()}."]  # fmt: skip
    hours = 1e4 * statistics.mean(walls) / 3600.0
    cores = os.cpu_count() or 1
    cost = (
        f"10,000 such runs take {hours:.1f} h of one worker's time: "
        f"{hours / cores:.1f} h on this machine's {cores} cores, "
        f"{hours / 16 * 60:.0f} min on 16 workers, {hours / 64 * 60:.0f} min on 64"
    )
    if result.ran and result.workers > 1:
        cost += (
            f" (this invocation: {result.ran} runs in {result.wall:.0f} s on "
            f"{result.workers} workers, {result.speedup:.2f} times one worker's pace)"
        )
    text.append(cost + ".")
    fig = study.figure
    if fig.get("kind", "none") != "none":
        if fig["kind"] == "threshold":
            what = f"the largest {fig['value']} with {fig['where']} at every smaller one"
        elif fig["kind"] == "line":
            names = ", ".join([fig["value"], *fig.get("also", [])])
            what = f"the means over the completed runs: {names}"
        else:
            what = f"the {fig['value']} at the least {fig['of']}"
        text.append(f"{what[0].upper()}{what[1:]}:\n\n{result_table(rows, fig)}")
    return "\n\n".join(text) + "\n"
