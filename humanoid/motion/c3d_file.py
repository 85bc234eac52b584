"""Opening a C3D file: its structure checked before ezc3d reads it.

ezc3d (the C++ reader) trusts a file's header and parameter section: a truncated file, or one
whose parameter section or header says more than the file holds, crashed the interpreter
(a segmentation fault, not an exception) in the fuzz of issue 38. :func:`open_c3d` walks the
header and the parameter section here first (the C3D guide's layout, C3D.ORG "The C3D File
Format User Guide", 2008, chapters 2 and 3) and refuses a file that does not hold what they
say with a :class:`~humanoid.motion.storage.MotionFileError` naming the file and the field.

The checks: the header's key byte (0x50); the parameter section's first block, block count
and processor type (Intel, DEC or MIPS) inside the file; every parameter entry's name, type
(-1 char, 1 byte, 2 integer, 4 float), dimensions (7 at most) and data inside the section;
``POINT:USED`` the header's count; ezc3d's ``ROTATION:RATIO`` at most 100; with analog
data, ``ANALOG:USED``, ``GEN_SCALE``, ``RATE`` and a ``SCALE`` and an ``OFFSET`` per
channel; the data's first block after the parameters; and the file long enough for the
frames the header counts (points and analog samples, integer or float as its scale factor's
sign says).
"""

from __future__ import annotations

import re
import struct
from pathlib import Path
from typing import NamedTuple

from ..errors import require
from .storage import MotionFileError

__all__ = ["Parameter", "check_c3d", "open_c3d", "parameter_table"]

BLOCK = 512  # [bytes] the C3D file's unit
PROCESSORS = {84: "<", 85: "<", 86: ">"}  # Intel, DEC (little-endian integers), MIPS
NAME = re.compile(rb"[A-Za-z0-9_ ]+")  # a group's or parameter's name (the guide: A-Z, 0-9, _)
MAX_DIMENSIONS = 7  # the C3D guide's limit on a parameter's dimensions
MAX_ENTRIES = 10_000  # a parameter section of more entries is corrupt (a loop of offsets)
MAX_RATIO = 100  # ezc3d's ROTATION:RATIO above this allocated without end (a hang)


class Parameter(NamedTuple):
    """A parameter entry of a C3D file: its number of ``values``, the first of them if an integer
    (``first``), its type (``kind``: -1 char, 1 byte, 2 integer, 4 float), its dimensions and
    the byte offset of its data in the file."""

    values: int
    first: int | None
    kind: int
    dims: tuple[int, ...]
    data: int


def check_c3d(path: str | Path) -> None:
    """Raise :class:`MotionFileError` naming ``path`` and the field unless the file's header
    and parameter section describe what the file holds (module docstring)."""
    parameter_table(path)


def parameter_table(path: str | Path) -> dict[tuple[str, str], Parameter]:
    """{(GROUP, NAME): :class:`Parameter`} of the file's parameter section, in the file's
    order, once the header and the section are checked (:func:`check_c3d`; a
    :class:`MotionFileError` if they do not describe what the file holds)."""
    path = Path(path)
    try:
        buf = path.read_bytes()
    except FileNotFoundError:
        raise MotionFileError(f"C3D file not found: {path}") from None
    except OSError as exc:
        raise MotionFileError(f"cannot read {path}: {exc}") from None
    size = len(buf)
    if size < 2 * BLOCK:
        raise MotionFileError(f"{path}: {size} bytes: not a C3D file (a header block and a "
                              f"parameter block at least)")  # fmt: skip
    if buf[1] != 0x50:
        raise MotionFileError(f"{path}: the header's key byte is {buf[1]:#x}, not 0x50: not a "
                              f"C3D file")  # fmt: skip
    first_block = buf[0]
    start = (first_block - 1) * BLOCK
    if first_block < 2 or start + 4 > size:
        raise MotionFileError(f"{path}: the header puts the parameters at block {first_block}, "
                              f"outside the file's {size // BLOCK} blocks")  # fmt: skip
    blocks, processor = buf[start + 2], buf[start + 3]
    if processor not in PROCESSORS:
        raise MotionFileError(f"{path}: processor type {processor} in the parameter section "
                              f"(84 Intel, 85 DEC, 86 MIPS): not a C3D file")  # fmt: skip
    end = start + blocks * BLOCK
    if blocks == 0 or end > size:
        raise MotionFileError(f"{path}: the parameter section's {blocks} blocks from block "
                              f"{first_block} run past the file's end ({size} bytes): a "
                              f"truncated file")  # fmt: skip
    order = PROCESSORS[processor]
    params = _parameters(path, buf, start, end, order)
    points, analogs, first, last = struct.unpack_from(order + "4H", buf, 2)
    data_block = struct.unpack_from(order + "H", buf, 16)[0]
    if data_block < first_block + blocks:
        raise MotionFileError(f"{path}: the header puts the data at block {data_block}, inside "
                              f"the parameter section (blocks {first_block}-"
                              f"{first_block + blocks - 1})")  # fmt: skip
    sign = {84: buf[15], 85: buf[13], 86: buf[12]}[processor] & 0x80
    word = 4 if sign else 2  # a negative scale factor: floats
    frames = max(last - first + 1, 0) if last != 0xFFFF else 0  # (long files: in TRIAL)
    need = (data_block - 1) * BLOCK + frames * (4 * points + analogs) * word
    if need > size:
        raise MotionFileError(f"{path}: the header counts {frames} frames of {points} points "
                              f"and {analogs} analog samples ({need} bytes); the file has "
                              f"{size}: a truncated file")  # fmt: skip
    used = params.get(("POINT", "USED"), (0, None))[1]
    if used is not None and used != points:
        raise MotionFileError(f"{path}: POINT:USED is {used}, the header counts {points} "
                              f"points")  # fmt: skip
    ratio = params.get(("ROTATION", "RATIO"), (0, 0))[1] or 0
    if not 0 <= ratio <= MAX_RATIO:  # ezc3d's own group: rotations per frame
        raise MotionFileError(f"{path}: ROTATION:RATIO is {ratio} (0-{MAX_RATIO} rotations per "
                              f"frame): corrupt")  # fmt: skip
    channels = params.get(("ANALOG", "USED"), (0, 0))[1] or 0
    if analogs:  # the channels' scales and offsets, one per channel (ezc3d reads them blind)
        for name in ("USED", "SCALE", "OFFSET", "GEN_SCALE", "RATE"):
            count = params.get(("ANALOG", name), (0, None))[0]
            need = channels if name in ("SCALE", "OFFSET") else 1
            if count < need:
                raise MotionFileError(f"{path}: ANALOG:{name} has {count} values for "
                                      f"{channels} channels: corrupt or missing")  # fmt: skip
    return params


def _parameters(path, buf: bytes, start: int, end: int, order: str) -> dict:
    """{(group, parameter): :class:`Parameter`}, after checking that every entry lies inside
    the section."""
    groups, ints = {}, {}
    i, count = start + 4, 0
    while i + 2 <= end:
        count += 1
        if count > MAX_ENTRIES:
            raise MotionFileError(f"{path}: the parameter section has more than "
                                  f"{MAX_ENTRIES} entries: corrupt")  # fmt: skip
        length, gid = struct.unpack_from("bb", buf, i)
        if length == 0:
            break
        j = i + 2 + abs(length)
        if j + 2 > end:
            raise MotionFileError(f"{path}: a parameter's name at byte {i} runs past the "
                                  f"parameter section")  # fmt: skip
        raw = buf[i + 2 : j]
        if not NAME.fullmatch(raw):
            raise MotionFileError(f"{path}: a parameter's name at byte {i + 2} is "
                                  f"{raw[:20]!r}, not letters, digits and _: corrupt")  # fmt: skip
        name = raw.decode("ascii").strip().upper()
        step = struct.unpack_from(order + "h", buf, j)[0]
        if gid < 0:
            if j + 3 > end or j + 3 + buf[j + 2] > end:
                raise MotionFileError(f"{path}: group {name!r}'s description runs past the "
                                      f"parameter section")  # fmt: skip
            _check_description(path, f"group {name!r}", buf[j + 2], j + 3, j, step)
            groups[-gid] = name
        else:
            if j + 4 > end:
                raise MotionFileError(f"{path}: parameter {name!r} runs past the parameter "
                                      f"section")  # fmt: skip
            kind, ndims = struct.unpack_from("bB", buf, j + 2)
            if kind not in (-1, 1, 2, 4):
                raise MotionFileError(f"{path}: parameter {name!r} has type {kind} (-1 char, "
                                      f"1 byte, 2 integer, 4 float): corrupt")  # fmt: skip
            if ndims > MAX_DIMENSIONS:
                raise MotionFileError(f"{path}: parameter {name!r} has {ndims} dimensions (at "
                                      f"most {MAX_DIMENSIONS}): corrupt")  # fmt: skip
            dims = buf[j + 4 : j + 4 + ndims]
            n = abs(kind)
            for d in dims:
                n *= d
            data = j + 4 + ndims
            if len(dims) != ndims or data + n + 1 > end or data + n + 1 + buf[data + n] > end:
                raise MotionFileError(f"{path}: parameter {name!r}'s data ({n} bytes) or "
                                      f"description runs past the parameter section")  # fmt: skip
            _check_description(path, f"parameter {name!r}", buf[data + n], data + n + 1, j, step)
            first = struct.unpack_from(order + "h", buf, data)[0] if kind == 2 and n else None
            ints[(gid, name)] = Parameter(n // abs(kind), first, kind, tuple(dims), data)
        if step == 0:
            break
        if step < 0 or j + step <= i:
            raise MotionFileError(f"{path}: parameter {name!r} points back to byte {j + step}: "
                                  f"corrupt")  # fmt: skip
        i = j + step
    orphans = sorted(n for g, n in ints if g not in groups)
    if orphans:
        raise MotionFileError(f"{path}: parameters {orphans[:5]} belong to no group: corrupt")
    return {(groups[g], n): v for (g, n), v in ints.items()}


def _check_description(path, what: str, length: int, at: int, j: int, step: int) -> None:
    """Refuse a description (``length`` characters from byte ``at``) that ezc3d cannot read:
    255 characters (it reads the length as a signed byte, -1, and crashed the interpreter,
    measured with ezc3d 1.7) or one that runs into the next entry (at ``j + step``; none if
    ``step`` is 0): ezc3d then read the next entries from the wrong bytes for 12-28 s before
    refusing the file."""
    if length == 255:
        raise MotionFileError(f"{path}: {what}'s description is 255 characters long, which "
                              f"ezc3d cannot read: corrupt?")  # fmt: skip
    if step and at + length > j + step:
        raise MotionFileError(f"{path}: {what}'s description ({length} characters) runs into "
                              f"the next entry: corrupt")  # fmt: skip


def open_c3d(path: str | Path):
    """The file read by ezc3d after :func:`check_c3d`; MotionFileError naming the file if
    either refuses it."""
    ezc3d = require("ezc3d", "reading a C3D file")
    check_c3d(path)
    try:
        return ezc3d.c3d(str(path))
    except Exception as exc:  # noqa: BLE001 - ezc3d raises RuntimeError, ValueError ...
        raise MotionFileError(f"cannot read {path} as C3D: {exc}") from None
