"""Child process of the C3D fuzz (tests/test_fuzz_files.py): reads mutated C3D files.

ezc3d, a C++ reader, crashed the interpreter on a truncated file (a segmentation fault), so
the reading happens here: a crash ends this process, not the test run. Cases: the file
truncated, bytes changed, a parameter's value or a data value replaced by a bad one. Before
each read the case is written to ``<out>.case``; each outcome is appended to ``<out>`` as one
JSON line. Usage: ``python fuzz_c3d_worker.py BASE.c3d N OUT``.
"""

from __future__ import annotations

import json
import struct
import sys
from pathlib import Path

import numpy as np
from fuzz_tools import finite, generator, outcome

from humanoid.motion.c3d import read_events, read_plates
from humanoid.motion.c3d_file import parameter_table
from humanoid.motion.markers import read_c3d


def _read(path):
    m = read_c3d(path)
    return (
        m.time,
        np.where(np.isnan(m.positions), 0.0, m.positions),
        [p.force for p in read_plates(path)],
        [e[0] for e in read_events(path)],
    )


def parameters(path) -> list[tuple[str, int, int, int]]:
    """(GROUP:NAME, type, data offset, data bytes) of every parameter, in the file's order."""
    return [(f"{group}:{name}", p.kind, p.data, p.values * abs(p.kind))
            for (group, name), p in parameter_table(path).items()]  # fmt: skip


NUMBERS = [np.nan, np.inf, -np.inf, 1e30, -1.0, 0.0, 1e9, 1e-30, 3.0, 255.0]


def mutated(blob: bytes, params, rng) -> tuple[bytes, str]:
    """A mutation of the file: truncated, bytes changed (in the header, the parameters,
    anywhere), a parameter's value replaced (a bad number, an integer, other characters), or
    a value of the data (points and analog samples) replaced by a bad number."""
    kind = int(rng.integers(0, 7))
    b = bytearray(blob)
    if kind == 0:
        k = int(rng.integers(0, len(blob)))
        return blob[:k], f"truncated at {k}"
    if kind in (1, 2, 3):
        end = (512, 512 * (blob[0] + 1), len(b))[kind - 1]
        at = rng.integers(0, end, int(rng.integers(1, 5)))
        for a in at:
            b[int(a)] = int(rng.integers(0, 256))
        return bytes(b), f"bytes {sorted(int(a) for a in at)} changed"
    if kind in (4, 5):
        name, ptype, at, n = params[int(rng.integers(0, len(params)))]
        if n == 0:
            return bytes(b), f"{name}: empty, unchanged"
        if ptype == 4:
            k = at + 4 * int(rng.integers(0, n // 4))
            value = float(rng.choice(NUMBERS))
            struct.pack_into("<f", b, k, value)
            return bytes(b), f"{name} float at {k} = {value}"
        if ptype == 2:
            k = at + 2 * int(rng.integers(0, n // 2))
            value = int(rng.choice([-1, 0, 1, 2, 7, 255, 32767, -32768]))
            struct.pack_into("<h", b, k, value)
            return bytes(b), f"{name} integer at {k} = {value}"
        k = at + int(rng.integers(0, n))
        b[k] = int(rng.choice([0, 32, ord("x"), 255, ord("m")]))
        return bytes(b), f"{name} byte at {k} = {b[k]}"
    data = (struct.unpack_from("<H", blob, 16)[0] - 1) * 512
    k = data + 4 * int(rng.integers(0, (len(blob) - data) // 4))
    value = float(rng.choice(NUMBERS))
    struct.pack_into("<f", b, k, value)
    return bytes(b), f"data float at {k} = {value}"


def main(base: str, n: int, out: str) -> None:
    blob = Path(base).read_bytes()
    params = parameters(base)
    rng = generator(38)
    out = Path(out)
    case, path = out.with_suffix(".case"), out.with_suffix(".c3d")
    with out.open("w") as f:
        for i in range(n):
            data, what = mutated(blob, params, rng)
            path.write_bytes(data)
            case.write_text(f"case {i}: {what}")
            result = outcome(lambda: _read(path), lambda r: finite(*r), seconds=5.0)
            f.write(json.dumps({"case": i, "what": what, "result": result}) + "\n")
            f.flush()


if __name__ == "__main__":
    main(sys.argv[1], int(sys.argv[2]), sys.argv[3])
