"""OpenSim's Storage files (``.sto``, ``.mot``) and CSV: read and write time tables.

A Storage file is a header of ``key=value`` lines (and a title) closed by ``endheader``, one
line of column labels (the first ``time``), then one row of numbers per sample, tab separated::

    walk
    version=1
    nRows=2
    nColumns=3
    inDegrees=yes
    endheader
    time	hip_flexion_r	knee_angle_r
    0.00	12.5	-4.1
    0.01	12.7	-4.3

OpenSim 4's TimeSeriesTable files add ``DataType``, a second ``version`` and
``OpenSimVersion`` lines; both layouts read the same. ``inDegrees`` says whether the angles are
in degrees; which columns are angles is the reader's to know (:mod:`~humanoid.motion.coordinates`).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from ..errors import HumanoidError

__all__ = [
    "MAX_RATE",
    "MAX_VALUE",
    "MotionFileError",
    "Table",
    "check_rate",
    "read_storage",
    "read_toml",
    "write_csv",
    "write_storage",
]

# [Hz] the highest sampling rate a motion file may have: motion capture runs at 50-2000 Hz,
# force plates at up to 10 kHz; a rate of 1e9 (or a step of 1e-12 s) is a corrupt header or
# time column, and every per-sample loop (resampling, filtering, inverse dynamics) would run
# for hours on it
MAX_RATE = 1e5
# [any unit] the largest magnitude of a value in a time table: no quantity of human motion
# comes near it in any unit a file uses (N, N mm, mm, degrees); beyond it a value is corrupt
# (a coordinate of 1e300 made the load estimation never return)
MAX_VALUE = 1e9


class MotionFileError(HumanoidError, ValueError):
    """A motion, marker or load file cannot be read: missing, malformed or inconsistent."""


@dataclass
class Table:
    """A time table: ``data[i, j]`` is column ``labels[j]`` at ``time[i]``.

    Attributes:
        time: Sample times [s], increasing, (n,).
        labels: Column labels (without ``time``).
        data: (n, len(labels)).
        in_degrees: The header's ``inDegrees`` (None if it has none).
        name: The title line. header: Every ``key=value`` of the header.
        source: Where it came from (a path, for messages).
    """

    time: np.ndarray
    labels: list[str]
    data: np.ndarray
    in_degrees: bool | None = None
    name: str = ""
    header: dict = field(default_factory=dict)
    source: str = ""

    def __post_init__(self) -> None:
        self.time = np.asarray(self.time, dtype=float).reshape(-1)
        if len(self.time) == 0:
            raise MotionFileError(f"{self.source or 'table'}: no rows of data")
        self.data = np.asarray(self.data, dtype=float).reshape(len(self.time), -1)
        if self.data.shape[1] != len(self.labels):
            raise MotionFileError(
                f"{self.source or 'table'}: {len(self.labels)} labels for "
                f"{self.data.shape[1]} columns"
            )
        if len(set(self.labels)) != len(self.labels):
            twice = sorted({x for x in self.labels if self.labels.count(x) > 1})
            raise MotionFileError(f"{self.source or 'table'}: repeated column labels {twice}")
        where = self.source or "table"
        if not np.all(np.isfinite(self.time)):
            i = int(np.flatnonzero(~np.isfinite(self.time))[0])
            raise MotionFileError(f"{where}: time is {self.time[i]} at sample {i + 1}")
        if np.any(np.isinf(self.data)) or np.nanmax(np.abs(self.data), initial=0.0) > MAX_VALUE:
            i, j = np.argwhere(~(np.abs(self.data) <= MAX_VALUE) & ~np.isnan(self.data))[0]
            raise MotionFileError(
                f"{where}: column {self.labels[j]!r} is {self.data[i, j]:g} at time "
                f"{self.time[i]:g} s: beyond {MAX_VALUE:g}, not a value of a motion"
            )
        if len(self.time) > 1 and not np.all(np.diff(self.time) > 0):
            i = int(np.flatnonzero(np.diff(self.time) <= 0)[0])
            raise MotionFileError(
                f"{self.source or 'table'}: time does not increase at row {i + 2} "
                f"({self.time[i]:g} then {self.time[i + 1]:g})"
            )

        check_rate(self.time, where)

    def __contains__(self, label: str) -> bool:
        return label in self.labels

    def column(self, label: str) -> np.ndarray:
        """One column by its label; raises MotionFileError listing the labels."""
        try:
            return self.data[:, self.labels.index(label)]
        except ValueError:
            raise MotionFileError(
                f"{self.source or 'table'} has no column {label!r}; its columns: "
                f"{', '.join(self.labels[:40])}{' ...' if len(self.labels) > 40 else ''}"
            ) from None

    @property
    def rate(self) -> float:
        """The mean sampling rate [Hz] (nan for fewer than two samples)."""
        if len(self.time) < 2:
            return math.nan
        return (len(self.time) - 1) / float(self.time[-1] - self.time[0])


def check_rate(time: np.ndarray, where: str) -> None:
    """Raise MotionFileError naming ``where`` if two samples of ``time`` [s] (increasing) are
    closer than 1 / :data:`MAX_RATE`."""
    if len(time) > 1:
        step = np.diff(time)
        i = int(np.argmin(step))
        if step[i] < 1.0 / MAX_RATE:
            raise MotionFileError(
                f"{where}: samples {i + 1} and {i + 2} are {step[i]:.3g} s apart (times "
                f"{time[i]:.9g}, {time[i + 1]:.9g}): a rate above {MAX_RATE:g} Hz, not a "
                "motion's; check the time column or the frame rate"
            )


def read_storage(path: str | Path) -> Table:
    """Read an OpenSim Storage file (``.sto``/``.mot``; see the module docstring).

    Raises:
        MotionFileError: naming the file and line: missing, no ``endheader``, no ``time``
            column, a row of the wrong length or with a non-number, time not increasing.
    """
    path = Path(path)
    try:
        lines = path.read_text(encoding="utf-8", errors="replace").splitlines()
    except FileNotFoundError:
        raise MotionFileError(f"motion file not found: {path}") from None
    except OSError as exc:
        raise MotionFileError(f"cannot read {path}: {exc}") from None
    end = next((i for i, x in enumerate(lines) if x.strip().lower() == "endheader"), None)
    if end is None:
        raise MotionFileError(
            f"{path}: no 'endheader' line: not an OpenSim Storage file (.sto/.mot)"
        )
    name = ""
    header: dict[str, str] = {}
    for i, line in enumerate(lines[:end]):
        key, sep, value = line.partition("=")
        if sep:
            header.setdefault(key.strip(), value.strip())
        elif i == 0:
            name = line.strip()
    body = [(i, x) for i, x in enumerate(lines[end + 1 :], start=end + 2) if x.strip()]
    if not body:
        raise MotionFileError(f"{path}: no column labels after 'endheader'")
    label_line, labels = body[0][0], _split(body[0][1])
    if not labels or labels[0].lower() != "time":
        raise MotionFileError(
            f"{path}:{label_line}: the first column must be 'time', got "
            f"{labels[0] if labels else 'nothing'!r}"
        )
    rows = []
    for number, line in body[1:]:
        cells = _split(line)
        if len(cells) != len(labels):
            raise MotionFileError(f"{path}:{number}: {len(cells)} values for {len(labels)} columns")
        try:
            rows.append([float(c) for c in cells])
        except ValueError:
            bad = next(c for c in cells if not is_number(c))
            raise MotionFileError(f"{path}:{number}: not a number: {bad!r}") from None
    data = np.array(rows, dtype=float).reshape(len(rows), len(labels))
    # (nRows and nColumns are not checked: OpenSim's own files are not always right about
    # them, e.g. a Moco example whose header says 40 columns for 32; the data counts)
    flag = header.get("inDegrees")
    in_degrees = None if flag is None else flag.strip().lower() in ("yes", "true", "1")
    return Table(data[:, 0], labels[1:], data[:, 1:], in_degrees, name, header, str(path))


def _split(line: str) -> list[str]:
    """A row's cells: tab separated (OpenSim), else whitespace."""
    cells = line.rstrip("\r\n").split("\t") if "\t" in line else line.split()
    return [c.strip() for c in cells if c.strip() != ""]


def is_number(text: str) -> bool:
    """Whether ``text`` reads as a float (the cell a parser names when a row fails)."""
    try:
        float(text)
    except ValueError:
        return False
    return True


def write_storage(path: str | Path, table: Table) -> Path:
    """Write ``table`` as an OpenSim Storage file (version 1, tab separated, full precision:
    what is read back is what was written, to the bit)."""
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    lines = [
        table.name or path.stem,
        "version=1",
        f"nRows={len(table.time)}",
        f"nColumns={len(table.labels) + 1}",
    ]
    if table.in_degrees is not None:
        lines.append(f"inDegrees={'yes' if table.in_degrees else 'no'}")
    skip = {"version", "nRows", "nColumns", "inDegrees"}
    lines += [f"{k}={v}" for k, v in table.header.items() if k not in skip]
    lines += ["endheader", "\t".join(["time", *table.labels])]
    block = np.column_stack([table.time, table.data])
    lines += ["\t".join(repr(float(x)) for x in row) for row in block]
    path.write_text("\n".join(lines) + "\n", encoding="utf-8")
    return path


def write_csv(path: str | Path, table: Table) -> Path:
    """Write ``table`` as CSV: a ``time`` column then the labels, full precision."""
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    block = np.column_stack([table.time, table.data])
    lines = [",".join(["time", *table.labels])]
    lines += [",".join(repr(float(x)) for x in row) for row in block]
    path.write_text("\n".join(lines) + "\n", encoding="utf-8")
    return path


def read_toml(path: str | Path, what: str) -> dict:
    """A TOML file's tables; HumanoidError naming ``what`` it should be if it is missing or
    not TOML."""
    import tomllib

    path = Path(path)
    try:
        return tomllib.loads(path.read_text(encoding="utf-8"))
    except FileNotFoundError:
        raise MotionFileError(f"{what} not found: {path}") from None
    except (tomllib.TOMLDecodeError, UnicodeDecodeError) as exc:
        raise MotionFileError(f"{path}: not TOML: {exc}") from None
    except OSError as exc:
        raise MotionFileError(f"cannot read {what} {path}: {exc}") from None
