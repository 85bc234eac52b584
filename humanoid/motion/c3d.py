"""Force plates and events of C3D files, read as recorded (types 1, 2, 3 and 4).

A C3D file keeps its force plates' raw analog channels and, in its ``FORCE_PLATFORM`` group,
how to turn them into loads (the C3D user guide, c3d.org, "The FORCE_PLATFORM group"):

- ``USED`` plates; ``TYPE`` per plate; ``CHANNEL`` (1-based analog channel numbers, 6 per plate
  for types 1, 2 and 4, 8 for type 3); ``CORNERS`` (3, 4, USED) in ``POINT:UNITS``, in the
  lab, numbered by the quadrant of the plate's own x-y plane they lie in: 1 (+x +y),
  2 (-x +y), 3 (-x -y), 4 (+x -y). The plate's axes in the lab come from them: x from corner 2
  to 1 (and 3 to 4), y from corner 4 to 1 (and 3 to 2), z = x times y. Plates' z points *down*
  into the floor by convention (corners clockwise seen from above); nothing here assumes it:
  whatever the corners say is used.
- ``ORIGIN`` (3, USED) in ``POINT:UNITS``, plate axes. Types 2 and 4: the vector **from the
  transducer's origin to the geometric centre of the top surface** (the origin lies below the
  surface and z points down, so its z is negative). Old AMTI calibration sheets give the
  opposite vector (positive z); as the C3D guide describes and as Visual3D and ezc3d do, an
  ORIGIN with a positive z is taken to be that one and negated whole. Type 3 (Kistler):
  ``(a, b, az0)``: the sensors' half spacings along x and y and the surface's offset from
  the sensors' plane (negative; a positive one is negated); Kistler's centre of pressure
  correction polynomials (``FPCOPPOLY``) are not applied (a warning says so). Type 1: not
  used (its channels give the centre of pressure on the surface directly).
- ``CAL_MATRIX`` (6, 6, USED), type 4 only: ``[Fx Fy Fz Mx My Mz] = CAL_MATRIX @ channels``,
  stored column by column (its first index is the row), moments in N times ``POINT:UNITS``
  (N mm for a millimetre lab). Type 2 has none (ignored if present, as the guide says).

The channels (``data["analogs"]`` of ezc3d, which has already applied ``ANALOG:OFFSET``,
``SCALE`` and ``GEN_SCALE``: ezc3d's ``Channel.cpp``) are, per type:

- 1: Fx, Fy, Fz, Px, Py (the centre of pressure on the surface, from its centre, plate axes),
  Tz (the free moment);
- 2 and 4: Fx, Fy, Fz, Mx, My, Mz about the transducer's origin;
- 3: fx12, fx34, fy14, fy23, fz1 ... fz4 (Kistler's: sensor k at (+-a, +-b) in corner k's
  quadrant); F = (fx12 + fx34, fy14 + fy23, sum fz), M = (b (fz1 + fz2 - fz3 - fz4),
  a (-fz1 + fz2 + fz3 - fz4), b (fx34 - fx12) + a (fy14 - fy23)) about the sensors' centre.

Types 1 and 2's moments are in the unit their channel's ``ANALOG:UNITS`` names (N m, N mm,
N cm), else (as ezc3d and Visual3D take them) in N times ``POINT:UNITS``; type 1's Px, Py in
their channel's length unit, else ``POINT:UNITS``; forces in N. About the top surface's
centre ``P`` (``o``: from the transducer's origin to ``P``; type 3: ``(0, 0, az0)``):
``M_P = M + F x o``; the centre of pressure on the surface ``(cx, cy, 0) = (-M_P,y / Fz,
M_P,x / Fz, 0)`` from ``P``; the free moment ``Tz = M_P,z - (cx Fy - cy Fx)`` (Kistler's
"Force plate formulae", the C3D guide's TYPE-2 page, Visual3D's FP_TYPE pages).

The channels are the wrench **the plate exerts on the subject** in the plate's axes (z down:
a standing subject's Fz is negative), as ezc3d's and BTK's force plate filters (and OpenSim's
C3D reader, BTK's) take them, and as recorded in Qualisys (AMTI), BTS and Kistler trials
(ezc3d's test files: their plates' vertical force is upward in the lab with no sign change).
A :class:`Plate` holds that ground reaction (upward when standing, OpenSim's convention), its
centre of pressure and its free moment (about the plate's normal), in the lab turned to our
axes (x forward, y left, z up) exactly as :func:`~humanoid.motion.markers.read_c3d` turns the
markers (Y up labs by ``POINT:Y_SCREEN``), metres and N m, at the analog rate. A plate whose
vertical force points down through its contacts (a file holding the force on the plate) is
read as recorded, with a :class:`PlateWarning`.

**Contact.** A plate is in contact while the force along its normal **pressing the subject
up** exceeds ``threshold`` (default 20 N); once in contact, it stays so until that force falls
below ``release`` (default half the threshold): a hysteresis, so that noise around the
threshold does not chatter. The force's sign counts: an unloaded plate's offset that pulls
down (real plates read -10 to -30 N when nobody stands on them and the file has no zeroing,
e.g. OpenSim's ``walking5.c3d``) is not a contact. A horizontal plate whose downward force
peaks higher than its upward one and above five times the threshold holds the force on the
plate (the opposite sign): its contacts are where that force exceeds the threshold, with a
:class:`PlateWarning`. A plate that is not horizontal (a wall's) uses the normal force's size.
Outside contact the centre of pressure is undefined: NaN, and the free moment 0 (the force is
kept as measured).

**Feet.** :func:`plate_loads` gives each contact of each plate to the foot whose markers are
nearest its centre of pressure (:func:`foot_markers` says which markers are a foot's), and
returns one :class:`~humanoid.motion.loads.Load` per foot, zero outside its contacts.
**Events** (``EVENT:TIMES``, ``CONTEXTS``, ``LABELS``) are read by :func:`read_events`.
"""

from __future__ import annotations

import re
import warnings
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from .c3d_file import open_c3d
from .loads import OPENSIM_TO_OURS, Load
from .storage import MAX_RATE, MotionFileError

__all__ = [
    "FOOT_NAMES",
    "FOOT_WORDS",
    "Plate",
    "PlateWarning",
    "assign_contacts",
    "c3d_contacts",
    "c3d_loads",
    "contact_loads",
    "foot_markers",
    "plate_loads",
    "read_events",
    "read_plates",
]

_LENGTH = {"mm": 1e-3, "cm": 1e-2, "m": 1.0}
_MOMENT = {"nmm": 1e-3, "ncm": 1e-2, "nm": 1.0}
_CHANNELS = {1: 6, 2: 6, 3: 8, 4: 6}


class PlateWarning(UserWarning):
    """A plate's contact that cannot be given to a foot (no foot markers, both feet as near,
    none near), or a parameter that is not applied (a Kistler plate's ``FPCOPPOLY``)."""


@dataclass
class Plate:
    """One force plate's loads over time, lab axes turned to ours (see the module docstring).

    Attributes:
        index: Its number in the file (1-based, ``FORCE_PLATFORM`` order). type: 1, 2, 3 or 4.
        corners: (4, 3) [m], the C3D order. origin: (3,) [m], the transducer's origin (type 1:
            the surface's centre).
        time: (n,) [s], the analog samples. force: (n, 3) [N], the ground reaction on the
            subject. cop: (n, 3) [m], the centre of pressure (NaN outside contact).
        free_moment: (n, 3) [N m], on the subject, along the plate's normal (0 outside
            contact). contact: (n,) bool.
        source: The file.
    """

    index: int
    type: int
    corners: np.ndarray
    origin: np.ndarray
    time: np.ndarray
    force: np.ndarray
    cop: np.ndarray
    free_moment: np.ndarray
    contact: np.ndarray = field(default_factory=lambda: np.zeros(0, dtype=bool))
    source: str = ""

    @property
    def name(self) -> str:
        return f"FP{self.index}"

    @property
    def centre(self) -> np.ndarray:
        """The top surface's centre [m] (the corners' mean)."""
        return self.corners.mean(axis=0)

    def contacts(self) -> list[tuple[int, int]]:
        """The contact intervals as sample ranges ``[start, stop)``."""
        c = np.concatenate([[False], np.asarray(self.contact, dtype=bool), [False]])
        edges = np.flatnonzero(np.diff(c.astype(np.int8)))
        return [(int(a), int(b)) for a, b in zip(edges[::2], edges[1::2], strict=True)]


def _open(path: str | Path):
    path = Path(path)
    if not path.exists():
        raise MotionFileError(f"C3D file not found: {path}")
    return open_c3d(path)


def _values(group: dict, name: str) -> np.ndarray | list | None:
    p = group.get(name)
    return None if p is None else p.get("value")


def _strings(group: dict, name: str) -> list[str]:
    """A string parameter with its continuations (``LABELS``, ``LABELS2`` ...)."""
    out, k = [], 2
    key = name
    while key in group:
        out += [str(x).strip() for x in group[key]["value"]]
        key, k = f"{name}{k}", k + 1
    return out


def _numbers(path, group: dict, name: str, where: str) -> np.ndarray:
    v = _values(group, name)
    if v is None:
        raise MotionFileError(f"{path}: no {where}:{name} parameter")
    try:
        a = np.asarray(v, dtype=float)
    except (TypeError, ValueError):
        raise MotionFileError(f"{path}: {where}:{name} is not numbers") from None
    return a


def _length_scale(path, point: dict) -> float:
    units = _strings(point, "UNITS")
    unit = units[0].lower() if units else "mm"
    scale = _LENGTH.get(unit)
    if scale is None:
        raise MotionFileError(f"{path}: unknown POINT:UNITS {unit!r} (mm, cm or m)")
    return scale


def _moment_scale(unit: str, length: float) -> float:
    u = re.sub(r"[\s.*\u00b7\u22c5-]", "", unit.lower())
    return _MOMENT.get(u, length)


def _lab_to_ours(c, y_up: bool | None) -> np.ndarray:
    if y_up is None:
        screen = c["parameters"]["POINT"].get("Y_SCREEN", {}).get("value", [""])
        y_up = bool(len(screen)) and str(screen[0]).strip().upper() == "+Y"
    return OPENSIM_TO_OURS if y_up else np.eye(3)


def _axes(corners: np.ndarray) -> np.ndarray | None:
    """The plate's axes in the lab (columns x, y, z) from its corners (see the module
    docstring); None if they are not finite or span no rectangle."""
    if not np.all(np.isfinite(corners)):
        return None
    x = (corners[0] - corners[1]) + (corners[3] - corners[2])
    y = (corners[0] - corners[3]) + (corners[1] - corners[2])
    z = np.cross(x, y)
    nx, ny, nz = np.linalg.norm(x), np.linalg.norm(y), np.linalg.norm(z)
    if not (nx > 0.0 and ny > 0.0 and nz > 0.5 * nx * ny) or np.ptp(corners) > 1e3:
        return None  # (degenerate, far from square, or beyond a kilometre: not a plate)
    x, z = x / nx, z / nz
    return np.column_stack([x, np.cross(z, x), z])


def _hysteresis(fn: np.ndarray, on: float, off: float) -> np.ndarray:
    """In contact from a sample above ``on`` until one below ``off`` (< on)."""
    n = len(fn)
    event = np.where(fn > on, 1, np.where(fn < off, -1, 0))
    last = np.maximum.accumulate(np.where(event != 0, np.arange(n), -1)) if n else event
    return (last >= 0) & (event[np.maximum(last, 0)] == 1)


def _contact(fz: np.ndarray, up: float, threshold: float, release: float):
    """(contact (n,) bool, whether the plate holds the force on it) of a plate's normal force
    ``fz`` (its axes) whose z is ``up`` along our vertical (see the module docstring)."""
    if abs(up) <= 0.9:  # not horizontal: the normal force's size
        return _hysteresis(np.abs(fz), threshold, release), False
    pressing = np.sign(up) * fz  # the vertical force on the subject, up positive
    top = float(np.max(pressing)) if len(fz) else 0.0
    bottom = float(np.max(-pressing)) if len(fz) else 0.0
    down = bottom > top and bottom > 5.0 * threshold
    contact = _hysteresis(-pressing if down else pressing, threshold, release)
    return contact, bool(down and contact.any())


def read_plates(path: str | Path, y_up: bool | None = None, threshold: float = 20.0,
                release: float | None = None) -> list[Plate]:  # fmt: skip
    """The force plates of a C3D file, as its ``FORCE_PLATFORM`` group describes them (see
    the module docstring).

    Args:
        path: The C3D file. y_up: The lab's vertical is its Y (turned to ours) or Z (kept);
            default from ``POINT:Y_SCREEN``, as :func:`~humanoid.motion.markers.read_c3d`.
        threshold: [N] the force along a plate's normal above which it is in contact.
        release: [N] below which a contact ends (default ``threshold / 2``).

    Returns:
        One :class:`Plate` per plate used, in the file's order.

    Raises:
        MotionFileError: naming the file and the parameter: a missing or unreadable file,
            no ``FORCE_PLATFORM`` group or none used, an unknown ``TYPE``, ``CORNERS``,
            ``ORIGIN``, ``CHANNEL`` or ``CAL_MATRIX`` of the wrong shape (or a type 4 plate
            without ``CAL_MATRIX``), a channel past the analog channels, no analog rate, no
            plate that can be placed.

    Warns:
        PlateWarning: a plate whose ``CORNERS`` span no rectangle (it is left out: some
            writers fill unused plates with garbage), a plate whose vertical force points
            down, a Kistler plate's ``FPCOPPOLY`` (not applied).
    """
    if not threshold > 0.0:
        raise MotionFileError(f"{path}: the contact threshold must be positive, got {threshold}")
    release = 0.5 * threshold if release is None else float(release)
    if not 0.0 < release <= threshold:
        raise MotionFileError(f"{path}: release must be in (0, threshold], got {release}")
    return _plates_of(_open(path), Path(path), y_up, threshold, release)


def _plates_of(c, path: Path, y_up, threshold: float, release: float) -> list[Plate]:
    """:func:`read_plates` of the opened file ``c``."""
    params = c["parameters"]
    fp = params.get("FORCE_PLATFORM")
    if fp is None:
        raise MotionFileError(f"{path}: no FORCE_PLATFORM group: no force plates")
    used_v = _values(fp, "USED")
    used = int(np.ravel(used_v)[0]) if used_v is not None and np.size(used_v) else 0
    if used <= 0:
        raise MotionFileError(f"{path}: FORCE_PLATFORM:USED is {used}: no force plates")
    length = _length_scale(path, params["POINT"])
    A = _lab_to_ours(c, y_up)

    types = _numbers(path, fp, "TYPE", "FORCE_PLATFORM").ravel()
    if types.size < used:
        raise MotionFileError(
            f"{path}: FORCE_PLATFORM:TYPE has {types.size} entries for USED={used} plates"
        )
    corners_all = _per_plate(path, fp, "CORNERS", (3, 4), used, "x y z of 4 corners")
    origin_all = _per_plate(path, fp, "ORIGIN", (3,), used, "x y z")
    channel_all = _numbers(path, fp, "CHANNEL", "FORCE_PLATFORM")
    if channel_all.ndim == 1 and used == 1:
        channel_all = channel_all[:, None]
    if channel_all.ndim != 2 or channel_all.shape[1] < used:
        raise MotionFileError(
            f"{path}: FORCE_PLATFORM:CHANNEL must be (channels per plate) x {used}, got shape "
            f"{channel_all.shape}"
        )

    analog = params.get("ANALOG", {})
    data = np.asarray(c["data"]["analogs"], dtype=float)
    n_channels = data.shape[1] if data.ndim == 3 else 0
    if n_channels == 0 or data.shape[2] == 0:
        raise MotionFileError(f"{path}: no analog data (ANALOG:USED is 0): no plate channels")
    signals = data[0]  # (channels, samples); ezc3d applied OFFSET, SCALE and GEN_SCALE
    rate_v = _values(analog, "RATE")
    rate = float(np.ravel(rate_v)[0]) if rate_v is not None and np.size(rate_v) else 0.0
    if not 0.0 < rate <= MAX_RATE:
        raise MotionFileError(f"{path}: ANALOG:RATE is {rate}: the plates' times are unknown "
                              f"(a rate in (0, {MAX_RATE:g}] Hz)")  # fmt: skip
    point_rate = float(np.ravel(params["POINT"]["RATE"]["value"])[0])
    first = int(c["header"]["points"]["first_frame"])
    start = first / point_rate if point_rate > 0 else 0.0
    time = start + np.arange(signals.shape[1]) / rate
    units = _strings(analog, "UNITS")
    units += [""] * (n_channels - len(units))

    plates = []
    for k in range(used):
        plate = _plate(path, fp, k, used, int(types[k]), channel_all, signals, units, length,
                       corners_all[:, :, k].T * length, origin_all[:, k] * length, A, time,
                       threshold, release)  # fmt: skip
        if plate is not None:
            plates.append(plate)
    if not plates:
        raise MotionFileError(f"{path}: none of its {used} force plates can be placed "
                              "(FORCE_PLATFORM:CORNERS)")  # fmt: skip
    return plates


def _plate(path, fp, k, used, kind, channel_all, signals, units, length, corners, origin, A,
           time, threshold, release) -> Plate | None:  # fmt: skip
    """Plate ``k`` of :func:`read_plates` (its ``corners`` (4, 3) and ``origin`` in the lab
    [m]; ``A`` the lab to our axes), or None (with a warning) if its corners span no
    rectangle."""
    n_channels = signals.shape[0]
    index = k + 1
    if kind not in _CHANNELS:
        raise MotionFileError(
            f"{path}: FORCE_PLATFORM:TYPE of plate {index} is {kind}: types 1, 2, 3 and 4 are read"
        )
    need = _CHANNELS[kind]
    if channel_all.shape[0] < need:
        raise MotionFileError(
            f"{path}: FORCE_PLATFORM:CHANNEL has {channel_all.shape[0]} channels per plate; "
            f"plate {index} (type {kind}) needs {need}"
        )
    numbers = channel_all[:need, k].astype(int)
    bad = [int(x) for x in numbers if not 1 <= x <= n_channels]
    if bad:
        raise MotionFileError(
            f"{path}: FORCE_PLATFORM:CHANNEL of plate {index} names analog channel(s) "
            f"{bad}: the file has channels 1 to {n_channels}"
        )
    ch = signals[numbers - 1].T  # (n, need)
    ch_units = [units[x - 1] for x in numbers]
    bad = [int(x) for x in numbers if not np.all(np.isfinite(signals[x - 1]))]
    if bad:
        raise MotionFileError(f"{path}: plate {index}'s analog channel(s) {bad} have "
                              "non-finite samples (or ANALOG:SCALE, OFFSET, GEN_SCALE are not "
                              "finite)")  # fmt: skip
    R = _axes(corners)
    if R is None:
        warnings.warn(
            f"{path}: FORCE_PLATFORM:CORNERS of plate {index} do not span a rectangle: "
            f"plate {index} left out",
            PlateWarning,
            stacklevel=3,
        )
        return None
    with np.errstate(over="ignore", invalid="ignore"):
        return _placed(path, fp, k, used, kind, index, ch, ch_units, length, corners, origin,
                       R, A, time, threshold, release)  # fmt: skip


def _placed(path, fp, k, used, kind, index, ch, ch_units, length, corners, origin, R, A, time,
            threshold, release) -> Plate:  # fmt: skip
    """The rest of :func:`_plate`: its force, centre of pressure and free moment (refused if
    they overflow: a calibration or scale too large)."""
    centre = corners.mean(axis=0)
    o = origin
    if kind == 1:  # the centre of pressure and the free moment as channels
        F = ch[:, :3].copy()
        lscale = [_LENGTH.get(u.lower(), length) for u in ch_units[3:5]]
        r = np.column_stack([ch[:, 3] * lscale[0], ch[:, 4] * lscale[1], np.zeros(len(ch))])
        T = ch[:, 5] * _moment_scale(ch_units[5], length)
        o = np.zeros(3)
    else:  # the force and the moment about the transducer's origin
        F, M, o = _wrench(path, fp, kind, k, used, ch, ch_units, o, length)
        MP = M + np.cross(F, o)  # about the top surface's centre
    up = (A @ R[:, 2])[2]  # the plate's z, our vertical
    contact, down = _contact(F[:, 2], up, threshold, release)
    if kind != 1:
        fz = np.where(contact, F[:, 2], 1.0)
        r = np.column_stack([-MP[:, 1] / fz, MP[:, 0] / fz, np.zeros(len(F))])
        T = MP[:, 2] - (r[:, 0] * F[:, 1] - r[:, 1] * F[:, 0])
    if not (np.all(np.isfinite(F)) and np.all(np.isfinite(np.where(contact, T, 0.0)))):
        raise MotionFileError(f"{path}: plate {index}'s force or moment is not finite "
                              "(FORCE_PLATFORM:CAL_MATRIX, ANALOG:SCALE or the channels "
                              "overflow)")  # fmt: skip
    cop = centre + r @ R.T
    cop[~contact] = np.nan
    free = np.where(contact, T, 0.0)[:, None] * R[:, 2]
    force = (F @ R.T) @ A.T
    if down:
        warnings.warn(
            f"{path}: plate {index}'s vertical force points down during its contacts "
            f"(mean {np.mean(force[contact, 2]):.0f} N): the file may hold the force on the "
            "plate rather than on the subject; read as recorded",
            PlateWarning,
            stacklevel=4,
        )
    return Plate(
        index=index, type=kind, corners=corners @ A.T, origin=A @ (centre - R @ o),
        time=time, force=force, cop=cop @ A.T, free_moment=free @ A.T,
        contact=contact, source=str(path),
    )  # fmt: skip


def _wrench(path, fp, kind, k, used, ch, ch_units, o, length):
    """(force [N], moment about the transducer's origin [N m], the vector from that origin
    to the top surface's centre [m]) of a type 2, 3 or 4 plate's channels, plate axes."""
    if kind == 3:  # Kistler: ORIGIN is (a, b, az0), the sensors' centre the origin
        poly = _values(fp, "FPCOPPOLY")
        if poly is not None and np.any(np.asarray(poly, dtype=float)):
            warnings.warn(
                f"{path}: FORCE_PLATFORM:FPCOPPOLY (Kistler's centre of pressure correction) "
                f"is not applied to plate {k + 1}",
                PlateWarning,
                stacklevel=3,
            )
        a, b, az0 = o
        F = np.column_stack([ch[:, 0] + ch[:, 1], ch[:, 2] + ch[:, 3], ch[:, 4:8].sum(axis=1)])
        M = np.column_stack([
            b * (ch[:, 4] + ch[:, 5] - ch[:, 6] - ch[:, 7]),
            a * (-ch[:, 4] + ch[:, 5] + ch[:, 6] - ch[:, 7]),
            b * (ch[:, 1] - ch[:, 0]) + a * (ch[:, 2] - ch[:, 3]),
        ])  # fmt: skip
        return F, M, np.array([0.0, 0.0, -abs(az0)])
    if kind == 4:
        w = ch @ _cal_matrix(path, fp, k, used).T
        F, M = w[:, :3], w[:, 3:] * length  # N (POINT:UNITS) to N m
    else:
        F = ch[:, :3].copy()
        M = ch[:, 3:] * np.array([_moment_scale(u, length) for u in ch_units[3:]])
    if o[2] > 0.0:  # the old AMTI sheets' vector, from the surface to the origin
        o = -o
    return F, M, o


def _cal_matrix(path, fp: dict, k: int, used: int) -> np.ndarray:
    v = _values(fp, "CAL_MATRIX")
    if v is None or np.size(v) == 0:
        raise MotionFileError(
            f"{path}: plate {k + 1} is type 4 but FORCE_PLATFORM:CAL_MATRIX is missing or empty"
        )
    C = _per_plate(path, fp, "CAL_MATRIX", (6, 6), k + 1, "a 6 x 6 matrix")[:, :, k]
    if not np.all(np.isfinite(C)):
        raise MotionFileError(f"{path}: FORCE_PLATFORM:CAL_MATRIX of plate {k + 1} not finite")
    return C


def _per_plate(path, fp: dict, name: str, shape: tuple, used: int, what: str) -> np.ndarray:
    """A FORCE_PLATFORM parameter of ``shape`` per plate, for at least ``used`` plates, as
    an array (*shape, plates) (the C3D's order: its first index runs fastest)."""
    a = _numbers(path, fp, name, "FORCE_PLATFORM")
    size = int(np.prod(shape))
    lead = a.shape[: len(shape)] if a.ndim > len(shape) else a.shape
    fits = a.size >= size * used and a.size % size == 0
    if not fits or (a.ndim > 1 and tuple(lead) != shape[: len(lead)]):
        dims = " x ".join(str(x) for x in (*shape, used))
        raise MotionFileError(
            f"{path}: FORCE_PLATFORM:{name} must be {dims} ({what} per plate), got shape {a.shape}"
        )
    if not np.all(np.isfinite(a)):
        raise MotionFileError(f"{path}: FORCE_PLATFORM:{name} has non-finite values")
    return a.reshape(-1, order="F").reshape((*shape, -1), order="F")


# -- feet ----------------------------------------------------------------------------------

# A foot marker's name: a side (L, R, Left, Right) before or after one of these words, e.g.
# LHEE, RTOE, LANK, R_MT5 (Plug-in Gait, CAST), R.Heel, L.Toe.Tip (OpenSim's gait2354),
# heel_r, toe_l, LeftHeel, Subject:RHEE (Vicon's subject prefix dropped), and the ISB/CAST
# landmarks Qualisys and Visual3D name: L_FCC (calcaneus), L_FM1, L_FM5 (metatarsal heads),
# L_FAL, L_TAM (malleoli)
FOOT_WORDS = ("HEE", "CAL", "TOE", "ANK", "MAL", "MT", "MET", "FOOT", "HALLUX")
FOOT_NAMES = ("FCC", "FM", "FAL", "TAM")  # whole words only (FME is the femur's epicondyle)
_NOT_FOOT = ("CALF",)


def _is_foot_word(text: str) -> bool:
    tokens = re.findall(r"[A-Z]+(?![a-z])|[A-Z]?[a-z]+|\d+", text)
    for t in (x.upper() for x in tokens):
        if t in FOOT_NAMES or (t.startswith(FOOT_WORDS) and not t.startswith(_NOT_FOOT)):
            return True
    return False


def _side_of(name: str) -> str | None:
    """The foot a marker's name puts it on (see :func:`foot_markers`), or None."""
    name = name.rsplit(":", 1)[-1].strip()
    sides = set()
    m = re.match(r"(?i)^(left|right)[\s._-]*(.+)$", name) or re.match(
        r"^([LRlr])(?:[\s._-]+|(?=[A-Z0-9]))(.+)$", name
    )
    if m and _is_foot_word(m.group(2)):
        sides.add("left" if m.group(1)[0].lower() == "l" else "right")
    m = re.match(r"(?i)^(.+?)[\s._-]+(left|right|l|r)$", name) or re.match(
        r"^(.*[a-z0-9])(Left|Right|L|R)$", name
    )
    if m and _is_foot_word(m.group(1)):
        sides.add("left" if m.group(2)[0].lower() == "l" else "right")
    return sides.pop() if len(sides) == 1 else None


def foot_markers(names) -> dict[str, list[int]]:
    """Which markers are on which foot: {"left": [indices], "right": [indices]}.

    A foot marker's name holds a side, ``L``/``R``/``Left``/``Right`` (any case for the
    words; a one-letter side is followed by a separator, a capital or a digit when it comes
    first, ``LHEE``, ``L.Heel``, and preceded by a separator or a lower-case letter when it
    comes last, ``heel_r``, ``HeelR``), before or after a word starting with one of
    :data:`FOOT_WORDS` (heel, calcaneus, toe, ankle, malleolus, metatarsal, foot, hallux;
    ``CALF`` is not one) or one of :data:`FOOT_NAMES` (ISB/CAST landmarks: FCC, FM1..FM5,
    FAL, TAM). A ``Subject:`` prefix is dropped. A name naming both sides is neither.
    """
    out: dict[str, list[int]] = {"left": [], "right": []}
    for i, n in enumerate(names):
        side = _side_of(str(n))
        if side is not None:
            out[side].append(i)
    return out


def assign_contacts(plates: list[Plate], markers=None, sides: dict[int, str] | None = None,
                    margin: float = 0.05, reach: float = 0.3) -> list[tuple]:  # fmt: skip
    """Each contact of each plate and the foot it goes to: a list of ``(plate, start, stop,
    side)`` (samples ``[start, stop)``; side ``"left"``, ``"right"`` or None), in the plates'
    order (see :func:`plate_loads`; it warns where it gives a contact to no foot)."""
    sides = dict(sides or {})
    side: str | None  # a plate's foot (None: no foot's)
    for index, side in sides.items():
        if side not in ("left", "right"):
            raise MotionFileError(f"plate {index}: its side must be left or right, not {side!r}")
    feet = foot_markers(markers.names) if markers is not None else {"left": [], "right": []}
    none = not (feet["left"] or feet["right"])
    if none and any(p.index not in sides and p.contacts() for p in plates):
        where = f" in {markers.source}" if markers is not None and markers.source else ""
        warnings.warn(
            f"{plates[0].source}: no foot markers{where} (names like LHEE, RTOE, R.Heel, "
            "toe_l): the plates' contacts are given to no foot",
            PlateWarning,
            stacklevel=3,
        )
    out = []
    for p in plates:
        for i0, i1 in p.contacts():
            if p.index in sides:
                side = sides[p.index]
            elif none:
                side = None
            else:
                side = _nearest_foot(p, i0, i1, markers, feet, margin, reach)
            out.append((p, i0, i1, side))
    return out


def plate_loads(plates: list[Plate], markers=None, sides: dict[int, str] | None = None,
                margin: float = 0.05, reach: float = 0.3) -> list[Load]:  # fmt: skip
    """The plates' contacts as the feet's loads: one :class:`~humanoid.motion.loads.Load`
    per foot that has any (``"left"``, ``"right"``), on the plates' time base, zero outside
    its contacts.

    Each contact interval of each plate goes to the foot whose markers (:func:`foot_markers`)
    are nearest, horizontally, to the interval's centre of pressure (its mean weighted by the
    normal force), the distance being the nearest of the foot's markers averaged over the
    marker frames of the interval. It goes to no foot, with a :class:`PlateWarning` naming
    the plate and the times, when the two feet are within ``margin`` [m] of each other's
    distance, when no foot is within ``reach`` [m], or when there are no foot markers. Where
    two plates carry one foot at once, their wrenches add (the centre of pressure on their
    mean height).

    Args:
        plates: From :func:`read_plates` (one time base). markers: The trial's
            :class:`~humanoid.motion.markers.MarkerTrajectories` (our axes), or None.
        sides: {plate index: "left" | "right"}: those plates' contacts all go to that foot,
            whatever the markers say.

    Raises:
        MotionFileError: plates on different time bases, a side neither left nor right.
    """
    return contact_loads(plates, assign_contacts(plates, markers, sides, margin, reach))


def contact_loads(plates: list[Plate], contacts: list[tuple]) -> list[Load]:
    """The feet's loads of the plates' ``contacts`` as :func:`assign_contacts` gives them
    (see :func:`plate_loads`).

    Raises:
        MotionFileError: plates on different time bases.
    """
    if not plates:
        return []
    time = plates[0].time
    for p in plates:
        if len(p.time) != len(time) or not np.allclose(p.time, time):
            raise MotionFileError(f"{p.source}: the plates' time bases differ ({p.name})")
    parts: dict[str, list[tuple[Plate, int, int]]] = {"left": [], "right": []}
    for p, i0, i1, side in contacts:
        if side is not None:
            parts[side].append((p, i0, i1))
    loads = []
    n = len(time)
    for side in ("left", "right"):
        if not parts[side]:
            continue
        count = np.zeros(n, dtype=int)
        wrench, height = np.zeros((n, 6)), np.zeros(n)
        force, point, torque = np.zeros((n, 3)), np.zeros((n, 3)), np.zeros((n, 3))
        for p, i0, i1 in parts[side]:
            s = slice(i0, i1)
            count[s] += 1
            f, c, tau = p.force[s], p.cop[s], p.free_moment[s]
            wrench[s] += np.hstack([f, np.cross(c, f) + tau])
            height[s] += f[:, 2] * c[:, 2]
            force[s], point[s], torque[s] = f, c, tau
        for i in np.flatnonzero(count > 1):  # one foot on two plates at once
            fz = wrench[i, 2]
            h = height[i] / fz if fz != 0.0 else 0.0
            x = Load.from_wrench(side, time[i : i + 1], wrench[i : i + 1], height=h)
            force[i], point[i], torque[i] = x.force[0], x.point[0], x.torque[0]
        names = "+".join(p.name for p in plates if any(q is p for q, _, _ in parts[side]))
        loads.append(Load(side, time, force, point, torque, names))
    return loads


def _nearest_foot(p: Plate, i0: int, i1: int, markers, feet, margin, reach) -> str | None:
    t0, t1 = float(p.time[i0]), float(p.time[i1 - 1])
    fn = np.abs(np.einsum("ij,j->i", p.force[i0:i1], _normal(p)))
    cop = (fn[:, None] * p.cop[i0:i1]).sum(0) / max(fn.sum(), 1e-300)
    frames = np.flatnonzero((markers.time >= t0) & (markers.time <= t1))
    if not frames.size:
        frames = np.array([int(np.argmin(np.abs(markers.time - 0.5 * (t0 + t1))))])
    dist = {}
    for side in ("left", "right"):
        if not feet[side]:
            dist[side] = np.inf
            continue
        xy = markers.positions[np.ix_(frames, feet[side])][..., :2]  # (frames, k, 2)
        d = np.linalg.norm(xy - cop[:2], axis=2)
        d = np.where(np.isfinite(d), d, np.inf).min(axis=1)
        d = d[np.isfinite(d)]
        dist[side] = float(d.mean()) if d.size else np.inf
    best, other = sorted(dist, key=dist.__getitem__)
    what = f"{p.source}: force plate {p.index} ({p.name}), contact {t0:.3f}-{t1:.3f} s"
    if not np.isfinite(dist[best]):
        warnings.warn(f"{what}: no foot marker seen then: given to no foot", PlateWarning,
                      stacklevel=3)  # fmt: skip
        return None
    if dist[best] > reach:
        warnings.warn(
            f"{what}: no foot within {reach:g} m of its centre of pressure (nearest: {best} "
            f"{dist[best]:.3f} m): given to no foot",
            PlateWarning,
            stacklevel=3,
        )
        return None
    if dist[other] - dist[best] < margin:
        warnings.warn(
            f"{what}: the feet are as near its centre of pressure (left {dist['left']:.3f} m, "
            f"right {dist['right']:.3f} m, less than {margin:g} m apart): ambiguous, given to "
            "no foot",
            PlateWarning,
            stacklevel=3,
        )
        return None
    return best


def _normal(p: Plate) -> np.ndarray:
    """The plate's z axis (its corners span a rectangle: :func:`read_plates` kept it)."""
    axes = _axes(p.corners)
    assert axes is not None  # read_plates kept only plates with axes
    return axes[:, 2]


def c3d_contacts(path: str | Path, threshold: float = 20.0,
                 sides: dict[int, str] | None = None,
                 y_up: bool | None = None) -> tuple[list[Plate], list[tuple]]:  # fmt: skip
    """A C3D file's plates and their contacts given to the feet by its own markers
    (:func:`read_plates`, :func:`assign_contacts`); a file without markers warns and gives
    its contacts to no foot unless ``sides`` names every plate's.

    Raises:
        MotionFileError: as :func:`read_plates`.
    """
    from .markers import read_c3d

    plates = read_plates(path, y_up=y_up, threshold=threshold)
    try:
        markers = read_c3d(path, y_up=y_up)
    except MotionFileError:
        markers = None  # no points: assign_contacts says so
    return plates, assign_contacts(plates, markers, sides)


def c3d_loads(path: str | Path, threshold: float = 20.0, sides: dict[int, str] | None = None,
              y_up: bool | None = None) -> tuple[list[Plate], list[Load]]:  # fmt: skip
    """A C3D file's plates and the feet's loads (:func:`c3d_contacts`, :func:`contact_loads`).

    Raises:
        MotionFileError: as :func:`read_plates`.
    """
    plates, contacts = c3d_contacts(path, threshold, sides, y_up)
    return plates, contact_loads(plates, contacts)


# -- events --------------------------------------------------------------------------------


def read_events(path: str | Path) -> list[tuple[float, str, str]]:
    """The events of a C3D file's ``EVENT`` group: (time [s], context, label) sorted by time,
    e.g. ``(1.25, "Left", "Foot Strike")``; an empty list if it has none. A time is
    ``60 TIMES(1, i) + TIMES(2, i)`` (minutes, seconds), on the file's clock (that of the
    markers' and the plates' times); a context or label the file leaves out is ``""``. The
    header's own event list is not read.

    Raises:
        MotionFileError: a missing or unreadable file, ``EVENT:TIMES`` that is not 2 x USED.
    """
    c = _open(path)
    group = c["parameters"].get("EVENT")
    if group is None:
        return []
    used_v = _values(group, "USED")
    used = int(np.ravel(used_v)[0]) if used_v is not None and np.size(used_v) else 0
    if used <= 0:
        return []
    times = _numbers(path, group, "TIMES", "EVENT")
    if times.ndim != 2 or times.shape[0] != 2 or times.shape[1] < used:
        raise MotionFileError(
            f"{path}: EVENT:TIMES must be 2 x {used} (minutes, seconds), got {times.shape}"
        )
    contexts, labels = _strings(group, "CONTEXTS"), _strings(group, "LABELS")
    contexts += [""] * (used - len(contexts))  # (some writers leave them out)
    labels += [""] * (used - len(labels))
    if not np.all(np.isfinite(times[:, :used])):
        raise MotionFileError(f"{path}: EVENT:TIMES has non-finite values")
    out = [(float(60.0 * times[0, i] + times[1, i]), contexts[i], labels[i]) for i in range(used)]
    return sorted(out, key=lambda e: e[0])
