"""Running a study on Dask: every pending run a task, rows written as runs finish.

By default a ``distributed.LocalCluster`` with one single-threaded worker process per core
runs the study; ``scheduler`` (an address, ``tcp://host:8786``) runs the same study on an
existing cluster unchanged, whose workers need ``humanoid`` installed (and, to keep
trajectories, the study's folder on a shared filesystem). Dask replaces a worker that dies
(its nanny restarts it) and reruns the task it held; a task whose workers die
``distributed.scheduler.allowed-failures`` times (3) becomes a failed row. ``serial`` runs
in this process, one after another, with the same code (the reference the tests compare the
cluster with).
"""

from __future__ import annotations

import contextlib
import math
import time
from collections import Counter
from dataclasses import asdict, dataclass, field
from pathlib import Path

from ..errors import StudyError, require
from .runner import execute
from .spec import Study
from .store import ResultStore

__all__ = ["StudyRun", "default_folder", "run_study"]

FLUSH_SECONDS = 2.0  # the table is rewritten at most this often (and at the end)
CONNECT_SECONDS = 10  # how long to wait for a --scheduler to answer


def default_folder(study: Study) -> Path:
    return Path("results") / "studies" / study.name


@dataclass
class StudyRun:
    """What one invocation did.

    Attributes:
        folder: The study's folder; table: its results table.
        total: Runs in the study; skipped: finished before this invocation; ran: finished
            in it; statuses: rows per status over the whole table.
        wall: This invocation's wall time [s]; run_time: the sum of its runs' own wall
            times [s] (run_time / wall: the speed-up the workers gave).
        workers: Worker processes (1 when serial).
        interrupted: Stopped by Ctrl-C (the rows so far are written).
    """

    folder: Path
    table: Path
    total: int
    skipped: int
    ran: int = 0
    statuses: dict = field(default_factory=dict)
    wall: float = 0.0
    run_time: float = 0.0
    workers: int = 1
    interrupted: bool = False

    @property
    def speedup(self) -> float:
        return self.run_time / self.wall if self.wall > 0 else math.nan


def run_study(study: Study, folder: str | Path | None = None, *, scheduler: str | None = None,
              workers: int | None = None, serial: bool = False, retry_failed: bool = False,
              fresh: bool = False, quiet: bool = False, client=None) -> StudyRun:  # fmt: skip
    """Run every run of ``study`` that has no row in ``folder`` yet (default
    results/studies/NAME); see the module docstring. ``client``: an existing
    ``distributed.Client`` to use (and leave open)."""
    folder = Path(folder) if folder is not None else default_folder(study)
    store = ResultStore(folder, study, fresh=fresh)
    runs = study.runs()
    done = store.finished(retry_failed)
    pending = [r for r in runs if r.id not in done]
    result = StudyRun(folder, store.path, len(runs), len(runs) - len(pending))
    payload = study.payload()
    bar = _bar(len(runs), result.skipped, quiet, study.name)
    # the finished rows by status, for the progress bar
    counts = Counter(r["status"] for k, r in store.rows.items() if k in done)
    bar.set_postfix_str(_tally(counts), refresh=False)
    last_flush = time.perf_counter()
    start = time.perf_counter()

    def finished(row: dict) -> None:
        nonlocal last_flush
        store.add(row)
        result.ran += 1
        result.run_time += float(row.get("wall_time", 0.0))
        counts[row["status"]] += 1
        bar.set_postfix_str(_tally(counts), refresh=False)
        bar.update(1)
        if time.perf_counter() - last_flush >= FLUSH_SECONDS:
            store.write()
            last_flush = time.perf_counter()

    try:
        if serial or not pending:
            from ..linalg import one_thread

            # one BLAS thread, as on a Dask worker: the same round-off, the same rows
            with one_thread():
                for run in pending:
                    finished(execute(payload, asdict(run), str(folder)))
        else:
            with _cluster(scheduler, workers, client) as c:
                result.workers = len(c.scheduler_info().get("workers", {})) or 1
                _submit_all(c, study, payload, pending, str(folder.resolve()), finished)
    except KeyboardInterrupt:
        result.interrupted = True
    finally:
        bar.close()
        store.write()
        result.wall = time.perf_counter() - start
    result.statuses = dict(Counter(r["status"] for r in store.rows.values()))
    return result


def _tally(counts: dict) -> str:
    """The progress bar's note: how many runs fell or failed so far."""
    parts = [f"{n} {s}" for s, n in sorted(counts.items()) if s != "completed"]
    return ", ".join(parts) if parts else "none failed"


def _submit_all(client, study, payload, pending, folder: str, finished) -> None:
    as_completed = require("distributed", "a study on Dask").as_completed

    shared = client.scatter(payload, broadcast=True)
    runs, futures = {}, []
    for run in pending:
        fut = client.submit(execute, shared, asdict(run), folder,
                            key=f"humanoid-run-{study.name}-{run.id}", pure=False)  # fmt: skip
        runs[fut.key] = run
        futures.append(fut)
    for fut in as_completed(futures):
        try:
            row = fut.result()
        except Exception as exc:  # KilledWorker: its worker died too often; or lost
            row = _lost_row(runs[fut.key], exc)
        finished(row)
        fut.release()


def _lost_row(run, exc) -> dict:
    name = type(exc).__name__
    why = ("its worker died each time it ran it" if name == "KilledWorker"
           else f"{name}: {exc}")  # fmt: skip
    return {"run": run.id, "index": run.index, **run.params, "status": "error",
            "message": why, "wall_time": 0.0, "trajectory": "", "worker": ""}  # fmt: skip


@contextlib.contextmanager
def _cluster(scheduler: str | None, workers: int | None, client=None):
    """A distributed client: the one given, one on ``scheduler``, or a LocalCluster of
    ``workers`` single-threaded processes (default: one per core)."""
    if client is not None:
        yield client
        return
    import logging
    import os

    distributed = require("distributed", "a study on Dask")
    Client, LocalCluster = distributed.Client, distributed.LocalCluster

    if scheduler is not None:
        try:
            client = Client(scheduler, timeout=CONNECT_SECONDS)
        except (OSError, TimeoutError, ValueError, TypeError) as exc:
            raise StudyError(f"cannot reach the Dask scheduler at {scheduler!r} within "
                             f"{CONNECT_SECONDS} s: {exc}") from None  # fmt: skip
        with client as c:
            yield c
        return
    n = workers or os.cpu_count() or 1
    with LocalCluster(n_workers=n, threads_per_worker=1, processes=True,
                      dashboard_address=":0", silence_logs=logging.CRITICAL) as cluster, \
            Client(cluster) as c:  # fmt: skip
        yield c


def _bar(total: int, initial: int, quiet: bool, name: str):
    from tqdm import tqdm

    return tqdm(total=total, initial=initial, unit="run", desc=name, disable=quiet,
                dynamic_ncols=True, smoothing=0.1)  # fmt: skip
