"""The fuzz suite's tools (tests/test_fuzz_files.py, tests/fuzz_c3d_worker.py): text
mutations, a per-case timeout and the outcome of one case.

A case ends in one of: ``finite`` (a result whose numbers are finite, as its check says),
``typed`` (a :class:`~humanoid.errors.HumanoidError`), ``non-finite`` (a NaN or inf where the
check wants none), ``hang`` (over its time), or ``untyped <Class>`` (any other exception; a
numpy RuntimeWarning counts as one: it is a computation on values nobody checked).

A fresh sample of the same kinds of cases (docs/robustness.md): ``HUMANOID_FUZZ_SEED`` (0, the
default: the suite's own cases) moves every generator and hypothesis's seed, and
``HUMANOID_FUZZ_SCALE`` multiplies every count (``assert len(rows) == ...`` follows it).
"""

from __future__ import annotations

import dataclasses
import os
import re
import signal
import traceback
import warnings
import zlib
from pathlib import Path

import numpy as np

from humanoid.errors import HumanoidError

# a number in a text file: not part of a word or a longer number
NUMBER = re.compile(r"(?<![\w.+-])[-+]?(?:\d+\.?\d*|\.\d+)(?:[eE][-+]?\d+)?(?![\w.])")
BAD_NUMBERS = ["nan", "inf", "-inf", "1e300", "-1e300", "-1", "0", "1e-300", "-0", "NaN",
               "123456789012345678901234567890", "1e999", "x", "", "0x10", "1,5"]  # fmt: skip
# a field's value replaced by another type (TOML, JSON)
BAD_VALUES = ["nan", "inf", "-inf", "1e300", "-1", "0", "99999999999999999999", '"x"', '""',
              "[]", "{}", "true", "[1, 2]", '["a"]', "[nan, nan, nan]", "1e-300"]  # fmt: skip
SEED = int(os.environ.get("HUMANOID_FUZZ_SEED", "0"))
SCALE = float(os.environ.get("HUMANOID_FUZZ_SCALE", "1"))
OPEN_ENDS = {"end"}  # a scene's contact: inf, it never ends
FIELD = re.compile(r"^(\s*[\w\"'.-]+\s*=\s*)(.+)$", re.M)


class Hang(Exception):
    """A case over its time."""


def cases(n: int) -> int:
    """The suite's count ``n`` times :data:`SCALE`."""
    return max(1, round(n * SCALE))


def generator(key: str | int) -> np.random.Generator:
    """The generator of ``key`` (a name, hashed, or a number), moved by :data:`SEED`."""
    k = zlib.crc32(key.encode()) if isinstance(key, str) else int(key)
    return np.random.default_rng(k if not SEED else [k, SEED])


def seeded(test):
    """A hypothesis test given :data:`SEED` (it wins over ``derandomize``; none at 0)."""
    from hypothesis import seed

    return seed(SEED)(test) if SEED else test


def _alarm(signum, frame):
    raise Hang


def outcome(fn, check=None, seconds: float = 5.0) -> str:
    """Run ``fn()`` with a timeout; the case's outcome (module docstring). Warnings other
    than RuntimeWarning are the package's own (typed) and ignored."""
    old = signal.signal(signal.SIGALRM, _alarm)
    signal.setitimer(signal.ITIMER_REAL, seconds)
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            warnings.simplefilter("error", RuntimeWarning)
            result = fn()
            ok = check is None or check(result)
    except Hang:
        return "hang"
    except HumanoidError:
        return "typed"
    except Exception as exc:  # noqa: BLE001 - what the fuzz looks for
        where = traceback.extract_tb(exc.__traceback__)[-1]
        return (f"untyped {type(exc).__name__}: {str(exc)[:200]} "
                f"(at {Path(where.filename).name}:{where.lineno})")  # fmt: skip
    finally:
        signal.setitimer(signal.ITIMER_REAL, 0)
        signal.signal(signal.SIGALRM, old)
    return "finite" if ok else "non-finite"


def finite(*values, nan_ok: bool = False) -> bool:
    """Every number in ``values`` (arrays, numbers, lists, dicts, dataclasses) is finite (or
    NaN, with ``nan_ok``: a missing marker's); a dataclass's field in :data:`OPEN_ENDS` may
    be +inf (a contact that never ends)."""
    for v in values:
        if v is None or isinstance(v, str | bytes | bool):
            continue
        if dataclasses.is_dataclass(v) and not isinstance(v, type):
            fields = [
                getattr(v, f.name)
                for f in dataclasses.fields(v)
                if not (f.name in OPEN_ENDS and getattr(v, f.name) == float("inf"))
            ]
            if not finite(*fields, nan_ok=nan_ok):
                return False
        elif isinstance(v, dict):
            if not finite(*v.values(), nan_ok=nan_ok):
                return False
        elif isinstance(v, list | tuple):
            if not finite(*v, nan_ok=nan_ok):
                return False
        elif isinstance(v, np.ndarray | float | int | np.number):
            a = np.asarray(v)
            if a.dtype.kind in "fc":
                bad = np.isinf(a) if nan_ok else ~np.isfinite(a)
                if bad.any():
                    return False
    return True


def mutate_text(text: str, rng: np.random.Generator, swaps=()) -> tuple[str, str]:
    """``text`` with one to three mutations, and their names: numbers replaced by bad ones,
    a field's value by another type, lines deleted, duplicated, swapped or shuffled, a
    field deleted, junk lines, the text truncated or emptied, bytes that are not UTF-8, and
    ``swaps`` (old, new) such as units replaced."""
    ops = ["number"] * 4 + ["value"] * 2 + ["delete", "duplicate", "swap", "shuffle",
           "token", "junk", "truncate"] + ["units"] * (2 if swaps else 0)  # fmt: skip
    names = []
    for _ in range(int(rng.integers(1, 4))):
        op = str(rng.choice(ops))
        if rng.random() < 0.02:
            op = str(rng.choice(["empty", "bytes"]))
        names.append(op)
        text = _mutate(text, op, rng, swaps)
    return text, "+".join(names)


def _mutate(text: str, op: str, rng, swaps) -> str:
    lines = text.split("\n")
    i = int(rng.integers(0, max(len(lines), 1)))
    if op == "number":
        found = list(NUMBER.finditer(text))
        if found:
            m = found[int(rng.integers(0, len(found)))]
            return text[: m.start()] + str(rng.choice(BAD_NUMBERS)) + text[m.end() :]
    elif op == "value":
        found = list(FIELD.finditer(text))
        if found:
            m = found[int(rng.integers(0, len(found)))]
            return text[: m.start(2)] + str(rng.choice(BAD_VALUES)) + text[m.end(2) :]
    elif op == "delete" and lines:
        del lines[i]
    elif op == "duplicate" and lines:
        lines.insert(i, lines[i])
    elif op == "swap" and len(lines) > 1:
        j = int(rng.integers(0, len(lines)))
        lines[i], lines[j] = lines[j], lines[i]
    elif op == "shuffle" and len(lines) > 2:
        j = min(len(lines), i + int(rng.integers(2, 6)))
        part = lines[i:j]
        rng.shuffle(part)
        lines[i:j] = part
    elif op == "token" and lines:
        cells = re.split(r"(\s+|,)", lines[i])
        words = [k for k, c in enumerate(cells) if c.strip(" \t,")]
        if words:
            del cells[words[int(rng.integers(0, len(words)))]]
            lines[i] = "".join(cells)
    elif op == "junk":
        junk = ["[", "]", "=", "x = ", "}", "{", "nan nan nan", "\t\t\t", "endheader", "[[x]]",
                '"', "MOTION"]  # fmt: skip
        lines.insert(i, str(rng.choice(junk)))
    elif op == "truncate":
        return text[: int(rng.integers(0, len(text) + 1))]
    elif op == "empty":
        return ""
    elif op == "bytes":
        k = int(rng.integers(0, len(text) + 1))
        return text[:k] + "\udcff\udcfe" + text[k:]
    elif op == "units" and swaps:
        old, new = swaps[int(rng.integers(0, len(swaps)))]
        return text.replace(old, new)
    return "\n".join(lines)


def write(path, text: str):
    """Write ``text`` (its lone surrogates as the bytes they stand for: not UTF-8)."""
    path.write_bytes(text.encode("utf-8", errors="surrogateescape"))
    return path
