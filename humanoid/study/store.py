"""A study's folder: the results table (Parquet, one row per run, rewritten as runs finish),
the study file it belongs to, and the kept trajectories.

The table is written whole to a temporary file and renamed over the old one (an atomic
replace on POSIX): a study killed at any moment leaves the last complete table, never a
truncated one. A row is keyed by its run id; a run that comes back twice (a retried task)
replaces its row, so no run is counted twice.
"""

from __future__ import annotations

import json
import math
import os
from pathlib import Path

from ..errors import StudyError, require

__all__ = ["ResultStore", "read_table"]

TABLE = "results.parquet"
STAMP = "study.json"


class ResultStore:
    """The rows of one study in ``folder`` (created if missing).

    Raises:
        StudyError: the folder holds the results of a different study (another name or
            fingerprint), unless ``fresh`` (then they are removed).
    """

    def __init__(self, folder: str | Path, study, fresh: bool = False) -> None:
        self.folder = Path(folder)
        self.path = self.folder / TABLE
        self.folder.mkdir(parents=True, exist_ok=True)
        stamp = self.folder / STAMP
        mine = {"name": study.name, "fingerprint": study.fingerprint, "source": study.source}
        if fresh:
            for old in (self.path, stamp):
                old.unlink(missing_ok=True)
        if stamp.is_file():
            theirs = json.loads(stamp.read_text())
            if (theirs.get("name"), theirs.get("fingerprint")) != (
                mine["name"],
                mine["fingerprint"],
            ):
                raise StudyError(
                    f"{self.folder} holds the results of another study ({theirs.get('name')} "
                    f"from {theirs.get('source')}, or this one before its set or base scene "
                    f"changed): give another --output, or --fresh to start over"
                )
        else:
            stamp.write_text(json.dumps(mine, indent=1))
        if study.text:
            (self.folder / "study.toml").write_text(study.text)
        self.rows: dict[str, dict] = {r["run"]: r for r in read_table(self.path)}

    def finished(self, retry_failed: bool = False) -> set[str]:
        """Ids of the runs with a row (with ``retry_failed``: those that did not fail)."""
        if not retry_failed:
            return set(self.rows)
        return {k for k, r in self.rows.items() if r["status"] not in ("failed", "error")}

    def add(self, row: dict) -> None:
        self.rows[row["run"]] = row

    def write(self) -> Path:
        """The table, every row so far in run order, atomically replaced."""
        pa = require("pyarrow", "a study's results table")
        pq = require("pyarrow.parquet", "a study's results table")

        rows = sorted(self.rows.values(), key=lambda r: r["index"])
        columns: dict[str, list] = {}
        for r in rows:
            for k in r:
                columns.setdefault(k, [])
        for k in columns:
            columns[k] = [_cell(r.get(k)) for r in rows]
        table = pa.table({k: _array(pa, v) for k, v in columns.items()})
        tmp = self.path.with_name(f".{TABLE}.{os.getpid()}.tmp")
        pq.write_table(table, tmp)
        os.replace(tmp, self.path)
        return self.path


def _cell(v):
    return v.item() if hasattr(v, "item") else v


def _array(pa, values: list):
    """A column: numbers as float64 (None as NaN) unless all are int or bool; strings as
    strings; a parameter with mixed types (a direction as a name or an angle) as strings."""
    kinds = {type(v) for v in values if v is not None}
    if kinds <= {bool}:
        return pa.array(values, type=pa.bool_())
    if kinds <= {int}:
        return pa.array(values, type=pa.int64())
    if kinds <= {int, float}:
        return pa.array([math.nan if v is None else float(v) for v in values], pa.float64())
    if kinds <= {str}:
        return pa.array(values, type=pa.string())
    return pa.array([None if v is None else str(v) for v in values], type=pa.string())


def read_table(path: str | Path) -> list[dict]:
    """The rows of a results table (none if there is no table yet). The file is read whole
    through one handle, then parsed: a running study replaces its table every few seconds, and
    pyarrow's reader, which opens a path twice (its size, then its pages), read the new file
    with the old one's size ("Page was smaller than expected")."""
    path = Path(path)
    if path.is_dir():
        path = path / TABLE
    try:
        with open(path, "rb") as handle:
            data = handle.read()
    except (FileNotFoundError, IsADirectoryError):
        return []
    pa = require("pyarrow", "a study's results table")
    pq = require("pyarrow.parquet", "a study's results table")
    return pq.read_table(pa.BufferReader(data)).to_pylist()
