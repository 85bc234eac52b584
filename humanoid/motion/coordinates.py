"""Joint coordinates in and out: OpenSim's gait models' coordinates and the toolkit's bodies.

A motion from OpenSim (an IK result ``.mot``) names the coordinates of the model it was solved
on. OpenSim's world is Y up (X forward, Z right); ours is z up (x forward, y left), so a
rotation about their axis ``a`` is one about ours ``C a`` (:data:`~humanoid.motion.loads.
OPENSIM_TO_OURS`): their Z (right) is our -y, their X our x, their Y our z. A joint with three
coordinates is a body-fixed sequence (rotation 1, then 2 about the turned axis, then 3: how
OpenSim's CustomJoint composes them, Simbody's ``FunctionBased`` mobilizer), which becomes one
quaternion of a ball joint here: no gimbal lock on the way in.

The built-in maps (:data:`MAPS`), onto the toolkit's bodies (``humanoid build``):

=========================  ======================  =========================================
OpenSim coordinates        body joint              axes, ours (sequence) and sign
=========================  ======================  =========================================
pelvis_tilt, _list,        root (free flyer)       -y, x, z; the root at the model's hip
_rotation; pelvis_tx,                              centres' midpoint (pelvis frame offset
_ty, _tz                                           below), tx, ty, tz -> x, z, -y [m]
hip_flexion_r, _adduction  right_hip (ball)        -y, x, z
_r, _rotation_r
hip_flexion_l, ...         left_hip (ball)         -y, -x, -z
knee_angle_r / _l          right_knee / left_knee  gait2354/2392: -1 (their flexion is
                                                   negative); Rajagopal: +1
ankle_angle_r / _l         *_ankle_flexion         +1 (dorsiflexion; their axis is 10 and 6
                                                   degrees off the lateral axis, ours on it)
subtalar_angle_r / _l      *_ankle_inversion       +1 (inversion; their axis is oblique,
                                                   ours the foot's long axis)
lumbar_extension,          lumbar and thoracic     -y, x, z; split equally between the two
_bending, _rotation        (balls)                 (each half the rotation), unless the
                                                   file has thoracic_* (then lumbar only)
arm_flex_r, arm_add_r,     right_shoulder (ball)   -y, x, z (left: -y, -x, -z); Rajagopal's
arm_rot_r                                          names, read and written with every map
elbow_flex_r / _l          *_elbow                 +1
wrist_flex_r, wrist_dev_r  *_wrist_flexion,        +1, -1 (their hand is in the anatomical
                           *_wrist_deviation       position, palm forward; ours palm in)
=========================  ======================  =========================================

``mtp_angle_r`` / ``_l`` go to ``*_mtp`` on a body built with toes (gait2392: +1, both
dorsiflexion; Rajagopal: -1, its axis is the opposite); on a one-piece foot they are left out
with a warning. Not mapped, listed in a warning: ``pro_sup``
(no forearm rotation), Rajagopal's knee ``_beta`` and anything else. The body's own extras are
written with names of the same form and read back: ``thoracic_extension, _bending,
_rotation`` and ``neck_extension, _bending, _rotation`` (-y, x, z). A body's coordinates written
with a map and read back with it give back the configuration to rounding.

A user map (TOML, :func:`read_map`) names the body's joints and the file's columns::

    name = "my lab's model"
    knee_sign_check = false            # optional
    [root]
    rotation = ["pelvis_tilt", "pelvis_list", "pelvis_rotation"]
    rotation_axes = ["-y", "x", "z"]
    translation = ["pelvis_tx", "pelvis_ty", "pelvis_tz"]
    translation_axes = ["x", "z", "-y"]
    offset = [-0.0707, 0.0, -0.0661]   # the body's root in the file's pelvis frame, ours [m]
    [joints.right_knee]
    columns = ["knee_angle_r"]
    signs = [-1]
    [joints.right_hip]
    columns = ["hip_flexion_r", "hip_adduction_r", "hip_rotation_r"]
    axes = ["-y", "x", "z"]
"""

from __future__ import annotations

import math
import warnings
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
import pinocchio as pin

from ..errors import CoordinateMapError, HumanoidError
from .storage import MotionFileError, Table, read_toml

__all__ = [
    "MAPS",
    "CoordinateMap",
    "JointMap",
    "RootMap",
    "UnmappedWarning",
    "configurations",
    "coordinates_table",
    "generalized_forces",
    "guess_map",
    "lowest_sole_point",
    "lowest_sole_points",
    "motion_floor",
    "read_map",
]

_AXES = {"x": 0, "y": 1, "z": 2}


class UnmappedWarning(UserWarning):
    """Columns of a motion file that no joint of the body takes."""


def _axis(text: str) -> np.ndarray:
    text = text.strip().lower()
    sign = -1.0 if text.startswith("-") else 1.0
    name = text.lstrip("+-")
    if name not in _AXES:
        raise CoordinateMapError(f"an axis is one of x, y, z with an optional sign, got {text!r}")
    a = np.zeros(3)
    a[_AXES[name]] = sign
    return a


@dataclass(frozen=True)
class JointMap:
    """Columns of a motion file that set joints of the body.

    Attributes:
        joints: The body's joint(s); several (a spine): the rotation is split equally.
        columns: The file's coordinates, in the order of the sequence.
        axes: For a ball joint, each column's rotation axis (``"x"``, ``"-y"``...: the body's
            frame, x forward, y left, z up), a body-fixed sequence. For a one-axis joint,
            ``signs`` instead. signs: The factor from the file's value to the joint's.
    """

    joints: tuple[str, ...]
    columns: tuple[str, ...]
    axes: tuple[str, ...] = ()
    signs: tuple[float, ...] = ()

    @property
    def ball(self) -> bool:
        return bool(self.axes)


@dataclass(frozen=True)
class RootMap:
    """The free flyer's columns: its rotation (a body-fixed sequence, like a ball joint's)
    and translation (each column along a signed axis of ours), and where the body's root is
    in the file's pelvis frame (``offset``, our axes) [m]."""

    rotation: tuple[str, ...]
    rotation_axes: tuple[str, ...]
    translation: tuple[str, ...]
    translation_axes: tuple[str, ...]
    offset: tuple[float, float, float] = (0.0, 0.0, 0.0)


@dataclass(frozen=True)
class CoordinateMap:
    """A motion file's coordinates onto a body (see the module docstring)."""

    name: str
    root: RootMap
    joints: tuple[JointMap, ...]
    ignored: tuple[str, ...] = ()  # known columns the body has no joint for
    extras: tuple[JointMap, ...] = field(default=())  # the body's own extra coordinates

    def columns(self) -> set[str]:
        out = set(self.root.rotation) | set(self.root.translation)
        for j in self.joints + self.extras:
            out |= set(j.columns)
        return out


def _side(s: str) -> str:
    return "right" if s == "r" else "left"


def _limbs(ball: str, coords: tuple[str, str, str], hinges) -> list[JointMap]:
    """Both sides' maps of a limb: a ball joint (``<side>_<ball>``) from three coordinates
    (``<coord>_r`` / ``_l``, OpenSim's Z, X, Y: the left's X and Y negated) and hinges
    (joint, coordinate, sign)."""
    out = []
    for s in "rl":
        side = _side(s)
        m = "" if s == "r" else "-"
        out.append(JointMap((f"{side}_{ball}",), tuple(f"{c}_{s}" for c in coords),
                            ("-y", f"{m}x", f"{m}z")))  # fmt: skip
        out += [JointMap((f"{side}_{j}",), (f"{c}_{s}",), signs=(sign,)) for j, c, sign in hinges]
    return out


def _legs(knee_sign: float) -> list[JointMap]:
    return _limbs("hip", ("hip_flexion", "hip_adduction", "hip_rotation"),
                  (("knee", "knee_angle", knee_sign), ("ankle_flexion", "ankle_angle", 1.0),
                   ("ankle_inversion", "subtalar_angle", 1.0)))  # fmt: skip


def _arms() -> list[JointMap]:
    return _limbs("shoulder", ("arm_flex", "arm_add", "arm_rot"),
                  (("elbow", "elbow_flex", 1.0), ("wrist_flexion", "wrist_flex", 1.0),
                   ("wrist_deviation", "wrist_dev", -1.0)))  # fmt: skip


_BACK = ("lumbar_extension", "lumbar_bending", "lumbar_rotation")
_THORACIC = ("thoracic_extension", "thoracic_bending", "thoracic_rotation")
_NECK = ("neck_extension", "neck_bending", "neck_rotation")
_SEQ = ("-y", "x", "z")  # OpenSim's Z, X, Y in our axes
_ROOT_COLUMNS = dict(
    rotation=("pelvis_tilt", "pelvis_list", "pelvis_rotation"), rotation_axes=_SEQ,
    translation=("pelvis_tx", "pelvis_ty", "pelvis_tz"), translation_axes=("x", "z", "-y"),
)  # fmt: skip
_EXTRAS = (JointMap(("thoracic",), _THORACIC, _SEQ), JointMap(("neck",), _NECK, _SEQ))
_IGNORED = ("mtp_angle_r", "mtp_angle_l", "pro_sup_r", "pro_sup_l", "knee_angle_r_beta",
            "knee_angle_l_beta")  # fmt: skip


def _map(name: str, knee_sign: float, hips: tuple[float, float, float], mtp_sign: float):
    # hips: the hip centres' midpoint in the unscaled model's pelvis frame (theirs, Y up)
    offset = (float(hips[0]), float(-hips[2]), float(hips[1]))
    toes = tuple(JointMap((f"{_side(s)}_mtp",), (f"mtp_angle_{s}",), signs=(mtp_sign,))
                 for s in "rl")  # used only where the body has toes  # fmt: skip
    return CoordinateMap(
        name, RootMap(offset=offset, **_ROOT_COLUMNS),
        tuple(_legs(knee_sign) + [JointMap(("lumbar", "thoracic"), _BACK, _SEQ)] + _arms()),
        _IGNORED, _EXTRAS + toes,
    )  # fmt: skip


# hip offsets from the models' .osim files (opensim-models: gait2354/gait2392 pelvis
# (-0.0707, -0.0661, +-0.0835), Rajagopal2016 (-0.056276, -0.07849, +-0.07726)). mtp_angle:
# gait2392 turns the toes about (-0.581, 0, 0.814) in the calcaneus frame (positive lifts the
# toe tip: dorsiflexion); Rajagopal's pin joint's frame turns its Z onto (0.581, 0, -0.814),
# the opposite axis (positive is plantarflexion), read from the two .osim files.
MAPS = {
    "gait2392": _map("gait2392", -1.0, (-0.0707, -0.0661, 0.0), 1.0),
    "gait2354": _map("gait2354", -1.0, (-0.0707, -0.0661, 0.0), 1.0),
    "rajagopal": _map("rajagopal", 1.0, (-0.056276, -0.07849, 0.0), -1.0),
}


def coordinate_name(label: str) -> str:
    """A column's coordinate name: OpenSim 4's state paths (``/jointset/hip_r/hip_flexion_r/
    value``) by their coordinate; anything else as it is."""
    parts = [p for p in label.split("/") if p]
    if len(parts) >= 2 and parts[-1] == "value":
        return parts[-2]
    return label


def guess_map(table: Table) -> CoordinateMap:
    """The built-in map a file's columns fit: by its knees (gait2354/2392's bend negative,
    Rajagopal's positive: the sign of the median), else Rajagopal's if it has arms, else
    gait2392's."""
    names = [coordinate_name(x) for x in table.labels]
    knees = [table.data[:, i] for i, x in enumerate(names) if x in ("knee_angle_r", "knee_angle_l")]
    if knees:
        median = float(np.median(np.concatenate(knees)))
        return MAPS["rajagopal" if median > 0.0 else "gait2392"]
    if {"arm_flex_r", "arm_flex_l"} & set(names):
        return MAPS["rajagopal"]
    return MAPS["gait2392"]


def read_map(path: str | Path) -> CoordinateMap:
    """A user map from TOML (see the module docstring).

    Raises:
        CoordinateMapError: missing file, bad TOML, a joint without columns, axes and columns of
            different lengths, an axis that is not one of x, y, z.
    """
    path = Path(path)
    spec = read_toml(path, "map file")
    unknown = set(spec) - {"name", "root", "joints", "ignored"}
    if unknown:
        raise CoordinateMapError(
            f"{path}: unknown keys {sorted(unknown)} (name, root, joints, ignored)"
        )
    root = spec.get("root")
    if not isinstance(root, dict):
        raise CoordinateMapError(f"{path}: a [root] table is required (rotation, translation ...)")
    for key in ("rotation", "rotation_axes", "translation", "translation_axes"):
        if key not in root:
            raise CoordinateMapError(f"{path}: [root] needs {key!r}")
    ox, oy, oz = _numbers(path, "root.offset", root.get("offset", (0.0, 0.0, 0.0)), 3)
    root_map = RootMap(
        _texts(path, "root.rotation", root["rotation"]),
        _texts(path, "root.rotation_axes", root["rotation_axes"]),
        _texts(path, "root.translation", root["translation"]),
        _texts(path, "root.translation_axes", root["translation_axes"]),
        (ox, oy, oz),
    )
    joints = []
    table = spec.get("joints") or {}
    if not isinstance(table, dict):
        raise CoordinateMapError(f"{path}: joints must be tables [joints.NAME]")
    for name, j in table.items():
        where = f"joints.{name}"
        if not isinstance(j, dict):
            raise CoordinateMapError(f"{path}: {where} must be a table (columns, axes or signs)")
        cols = _texts(path, f"{where}.columns", j.get("columns", ()))
        names = _texts(path, f"{where}.joints", j["joints"]) if "joints" in j else (name,)
        jm = JointMap(
            names,
            cols,
            _texts(path, f"{where}.axes", j.get("axes", ())),
            _numbers(path, f"{where}.signs", j.get("signs", ())),
        )
        if not cols or len(jm.axes or jm.signs) != len(cols) or (jm.axes and jm.signs):
            raise CoordinateMapError(
                f"{path}: joints.{name}: give 'columns' and, one per column, 'axes' (a ball "
                "joint) or 'signs' (a one-axis joint)"
            )
        joints.append(jm)
    for key in ("rotation", "rotation_axes", "translation", "translation_axes"):
        _texts(path, f"root.{key}", root[key], 3)  # three each (checked after the joints')
    for jm in [*joints, JointMap(("root",), root_map.rotation, root_map.rotation_axes)]:
        for a in jm.axes:
            try:
                _axis(a)
            except HumanoidError as exc:
                raise CoordinateMapError(f"{path}: {jm.joints[0]}: {exc}") from None
    name = spec.get("name", path.stem)
    if not isinstance(name, str):
        raise CoordinateMapError(f"{path}: name must be a string, got {name!r}")
    return CoordinateMap(name, root_map, tuple(joints),
                         _texts(path, "ignored", spec.get("ignored", ())))  # fmt: skip


def _texts(path, key: str, value, n: int | None = None) -> tuple[str, ...]:
    """``value`` as a tuple of strings (of ``n``, if given); HumanoidError naming the file and
    ``key`` if it is not a list of strings."""
    if not isinstance(value, list | tuple) or not all(isinstance(x, str) for x in value):
        raise CoordinateMapError(f"{path}: {key} must be a list of strings, got {value!r}")
    if n is not None and len(value) != n:
        raise CoordinateMapError(f"{path}: {key} must have {n} entries, got {len(value)}")
    return tuple(value)


def _numbers(path, key: str, value, n: int | None = None) -> tuple[float, ...]:
    """``value`` as a tuple of finite floats (of ``n``, if given); HumanoidError naming the file
    and ``key`` otherwise (booleans are not numbers)."""
    ok = isinstance(value, list | tuple) and all(
        isinstance(x, int | float) and not isinstance(x, bool) and math.isfinite(x) for x in value
    )
    if not ok or (n is not None and len(value) != n):
        size = f"{n} " if n is not None else "a list of "
        raise CoordinateMapError(f"{path}: {key} must be {size}finite numbers, got {value!r}")
    return tuple(float(x) for x in value)


def _sequence(values: np.ndarray, axes) -> np.ndarray:
    """The rotation of a body-fixed sequence: R = R(a1, v1) R(a2, v2) R(a3, v3)."""
    R = np.eye(3)
    for v, a in zip(values, axes, strict=True):
        R = R @ pin.exp3(_axis(a) * float(v))
    return R


def _angles(R: np.ndarray, axes) -> np.ndarray:
    """The angles of a body-fixed sequence of three distinct (signed) axes that give R."""
    from scipy.spatial.transform import Rotation

    vecs = [_axis(a) for a in axes]
    letters = "".join("XYZ"[int(np.flatnonzero(v)[0])] for v in vecs)
    if len(set(letters)) != 3:
        raise CoordinateMapError(f"a rotation sequence needs three different axes, got {axes}")
    signs = np.array([v.sum() for v in vecs])
    return Rotation.from_matrix(R).as_euler(letters) * signs


def _joint(model, name: str) -> int:
    if not model.existJointName(name):
        raise CoordinateMapError(
            f"the map names joint {name!r}, which this body does not have: the built-in maps "
            "are for the toolkit's bodies (humanoid build); give a map of your own (TOML)"
        )
    return model.getJointId(name)


def _set_rotation(model, q, joint: int, R: np.ndarray) -> None:
    j = model.joints[joint]
    if j.nq == 4:  # a ball joint: its quaternion (x, y, z, w)
        q[j.idx_q : j.idx_q + 4] = pin.Quaternion(R).coeffs()
    else:
        raise CoordinateMapError(
            f"joint {model.names[joint]!r} is not a ball joint ({j.shortname()})"
        )


def _set_joints(h, table: Table, cmap: CoordinateMap, cols: dict, q: np.ndarray, scale: float,
                in_degrees: bool) -> set[str]:  # fmt: skip
    """The joints' rows of q set from the map's columns [rad after ``scale``] (the map's extras
    the file and the body both have too); the columns used, the root's included."""
    model, n = h.model, len(q)
    used = set(cmap.root.rotation) | set(cmap.root.translation)
    extras = {
        j.joints[0]: j
        for j in cmap.extras  # a body without toes skips mtp_angle
        if all(c in cols for c in j.columns) and all(map(model.existJointName, j.joints))
    }
    for jm in (*cmap.joints, *extras.values()):
        present = [c in cols for c in jm.columns]
        if not any(present):
            continue
        if not all(present):
            missing = [c for c, p in zip(jm.columns, present, strict=True) if not p]
            raise MotionFileError(f"{table.source}: {jm.joints} needs {missing} too")
        used |= set(jm.columns)
        for c in jm.columns:
            _check_angle(table, c, cols[c] * scale, in_degrees)
        ids = [_joint(model, name) for name in jm.joints]
        if "thoracic" in extras and len(ids) > 1 and "thoracic" in jm.joints:
            ids = ids[:1]  # the file has the thoracic's own: lumbar_* is the lumbar's alone
        values = np.column_stack([cols[c] for c in jm.columns]) * scale
        if jm.ball:
            for i in range(n):
                R = _sequence(values[i], jm.axes)
                if len(ids) > 1:  # split equally along the rotation
                    R = pin.exp3(pin.log3(R) / len(ids))
                for j in ids:
                    _set_rotation(model, q[i], j, R)
        else:
            for j, s in zip(ids, jm.signs, strict=False):
                q[:, model.joints[j].idx_q] = s * values[:, 0]
    return used


def configurations(h, table: Table, cmap: CoordinateMap | None = None, *, floor: bool = True,
                   degrees: bool | None = None) -> tuple[np.ndarray, np.ndarray, list]:  # fmt: skip
    """The body's configurations over a coordinate file's times.

    Args:
        h: The body. table: The coordinates (:func:`~humanoid.motion.storage.read_storage`).
        cmap: The map (default :func:`guess_map`). floor: Move the motion up or down so that
            its floor (:func:`motion_floor`: where its stances are) is at z = 0: the body is
            not the model the motion was solved on, and its legs are not that model's length.
        degrees: Whether the angles are in degrees (default: the file's ``inDegrees``, else
            yes, as OpenSim writes coordinates).

    Returns:
        (time, q (n, nq), the file's columns no joint takes). Those are also warned about
        (:class:`UnmappedWarning`), and joints no column sets stay at the body's standing
        posture.

    Raises:
        CoordinateMapError: a mapped joint missing from the body; MotionFileError: a column the
            map needs missing from the file (the root's rotation and translation are needed).
    """
    model = h.model
    cmap = cmap or guess_map(table)
    cols = {coordinate_name(x): table.data[:, i] for i, x in enumerate(table.labels)}
    if len(cols) != len(table.labels):
        raise MotionFileError(f"{table.source}: two columns name the same coordinate")
    in_degrees = degrees if degrees is not None else (table.in_degrees is not False)
    scale = math.pi / 180.0 if in_degrees else 1.0
    for name in (*cmap.root.rotation, *cmap.root.translation):
        if name not in cols:
            raise MotionFileError(
                f"{table.source or 'the motion'}: the {cmap.name} map needs column {name!r} (the "
                f"pelvis); the file has {', '.join(sorted(cols)[:30])}"
            )
    for jm in cmap.joints:  # a map is for one kind of body: all of its joints, or none
        for name in jm.joints:
            _joint(model, name)
    n = len(table.time)
    q = np.tile(h.standing_configuration(), (n, 1))
    used = _set_joints(h, table, cmap, cols, q, scale, in_degrees)
    for c in sorted(used):
        gaps = np.flatnonzero(np.isnan(cols[c]))
        if gaps.size:
            raise MotionFileError(
                f"{table.source or 'the motion'}: column {c!r} is NaN at {gaps.size} samples "
                f"(first at {table.time[gaps[0]]:g} s): a coordinate needs a value at every "
                "sample (fill the gaps first)"
            )
    _set_root(q, cols, cmap.root, scale)
    if floor:
        q[:, 2] -= motion_floor(h, q)
    unmapped = [x for x in cols if x not in used and x not in cmap.ignored]
    skipped = [x for x in cols if x not in used and x in cmap.ignored]
    if unmapped or skipped:
        warnings.warn(
            f"{table.source or 'motion'}: columns the body has no joint for, left out: "
            f"{', '.join(skipped + unmapped)}",
            UnmappedWarning,
            stacklevel=2,
        )
    return table.time.copy(), q, skipped + unmapped


# [rad] the largest angle a joint's coordinate may have: no joint of a person turns a full
# turn (the root's heading, which may wind over a turn, is not checked); an elbow at 140 "rad"
# is a file in degrees whose header says inDegrees=no
MAX_JOINT_ANGLE = 2.0 * math.pi


def _check_angle(table: Table, column: str, radians: np.ndarray, in_degrees: bool) -> None:
    """Raise MotionFileError naming the file and ``column`` if its angles [rad] reach
    :data:`MAX_JOINT_ANGLE`, saying which unit the numbers look like."""
    largest = float(np.nanmax(np.abs(radians), initial=0.0))
    if largest < MAX_JOINT_ANGLE:
        return
    as_read = f"{math.degrees(largest):.0f} deg" if not in_degrees else f"{largest:.3g} rad"
    hint = (
        "the numbers look like degrees: set inDegrees=yes in its header"
        if not in_degrees
        else "more than a full turn: the column is not a joint angle"
    )
    raise MotionFileError(
        f"{table.source or 'the motion'}: column {column!r} reaches {as_read} (read as "
        f"{'degrees' if in_degrees else 'radians'}): {hint}"
    )


def _set_root(q: np.ndarray, cols: dict, root: RootMap, scale: float) -> None:
    """The root's rows of q: its rotation, and its position (the file's pelvis origin, moved to
    ours)."""
    rot = np.column_stack([cols[c] for c in root.rotation]) * scale
    axes_t = np.array([_axis(a) for a in root.translation_axes])
    trans = np.column_stack([cols[c] for c in root.translation]) @ axes_t
    offset = np.array(root.offset)
    for i in range(len(q)):
        R = _sequence(rot[i], root.rotation_axes)
        q[i, :3] = trans[i] + R @ offset
        q[i, 3:7] = pin.Quaternion(R).coeffs()


def lowest_sole_point(h, q: np.ndarray) -> float:
    """The lowest height any sole point reaches over the configurations (each point on its
    own frame: a foot with free toes carries its toe points on them)."""
    return float(lowest_sole_points(h, q).min(initial=math.inf))


def lowest_sole_points(h, q: np.ndarray) -> np.ndarray:
    """Per configuration, the height of its lowest sole point (n,)."""
    model = h.model
    data = model.createData()
    frames = [h.frame_id(n) for s in ("left", "right") for n in h.require_contact_points(s)]
    low = np.full(len(q), math.inf)
    for i, qi in enumerate(q):
        pin.forwardKinematics(model, data, qi)
        for f in frames:
            low[i] = min(low[i], float(pin.updateFramePlacement(model, data, f).translation[2]))
    return low


def motion_floor(h, q: np.ndarray) -> float:
    """The height of a motion's floor: the median over its configurations of the lowest sole
    point. In a walk a foot always stands, so this is where the stances are; the lowest of
    all is an outlier (a rigid foot's tip through the floor at push-off, 4-5 cm under
    walking5's stances; a noisy frame's swinging foot), under which the stances would float."""
    return float(np.median(lowest_sole_points(h, q)))


def coordinates_table(h, time, q, cmap: CoordinateMap | str = "rajagopal",
                      degrees: bool = True, name: str = "Coordinates") -> Table:  # fmt: skip
    """The body's configurations as a coordinate file of ``cmap``'s names (OpenSim's), plus
    the body's own extras (``thoracic_*``, ``neck_*``): the inverse of :func:`configurations`
    (with ``floor=False``)."""
    model = h.model
    cmap = MAPS[cmap] if isinstance(cmap, str) else cmap
    q = np.asarray(q, dtype=float).reshape(len(time), model.nq)
    scale = 180.0 / math.pi if degrees else 1.0
    labels, cols = [], []
    rot = np.zeros((len(q), 3))
    trans = np.zeros((len(q), 3))
    axes_t = np.array([_axis(a) for a in cmap.root.translation_axes])
    offset = np.array(cmap.root.offset)
    for i, qi in enumerate(q):
        R = pin.Quaternion(qi[3:7]).normalized().toRotationMatrix()
        rot[i] = _angles(R, cmap.root.rotation_axes)
        trans[i] = axes_t @ (qi[:3] - R @ offset)
    labels += [*cmap.root.rotation, *cmap.root.translation]
    cols += [rot * scale, trans]
    has = {j.joints[0] for j in cmap.extras if all(model.existJointName(n) for n in j.joints)}
    for jm in (*cmap.joints, *[j for j in cmap.extras if j.joints[0] in has]):
        if not all(model.existJointName(n) for n in jm.joints):
            continue
        ids = [model.getJointId(n) for n in jm.joints]
        if "thoracic" in has and len(ids) > 1 and "thoracic" in jm.joints:
            ids = ids[:1]
        if jm.ball:
            values = np.zeros((len(q), 3))
            for i, qi in enumerate(q):
                R = np.eye(3)
                for j in ids:
                    k = model.joints[j].idx_q
                    R = R @ pin.Quaternion(qi[k : k + 4]).normalized().toRotationMatrix()
                values[i] = _angles(R, jm.axes)
            cols.append(values * scale)
        else:
            cols.append(np.column_stack([q[:, model.joints[ids[0]].idx_q] * jm.signs[0]])
                        * scale)  # fmt: skip
        labels += list(jm.columns)
    return Table(np.asarray(time, dtype=float), labels, np.hstack(cols), degrees, name)


def _sequence_axes(values: np.ndarray, axes) -> np.ndarray:
    """The rotation axes of a body-fixed sequence at ``values``, in the parent's frame, (3, 3)
    one per row: the i-th turned by the rotations before it."""
    R, out = np.eye(3), []
    for v, a in zip(values, axes, strict=True):
        out.append(R @ _axis(a))
        R = R @ pin.exp3(_axis(a) * float(v))
    return np.array(out)


def generalized_forces_table(h, time, q, tau, cmap: CoordinateMap | str = "rajagopal",
                             name: str = "Inverse Dynamics") -> Table:  # fmt: skip
    """Generalised forces ``tau`` (n, nv: a joint's moment about its own axes, a ball joint's
    in its child frame) as the forces of ``cmap``'s coordinates, named as OpenSim's inverse
    dynamics names them (``hip_flexion_r_moment``, ``pelvis_tx_force``...): for a sequence of
    rotations, the moment projected on each rotation's axis (the force that does the same
    work through that coordinate); for a one-axis joint its moment times the map's sign; for
    the root, the residual force along each translation axis and the residual moment about the
    file's pelvis origin projected as for a ball joint."""
    model = h.model
    cmap = MAPS[cmap] if isinstance(cmap, str) else cmap
    coords = coordinates_table(h, time, q, cmap, degrees=False)
    cols = {x: coords.data[:, i] for i, x in enumerate(coords.labels)}
    tau = np.asarray(tau, dtype=float).reshape(len(time), model.nv)
    n = len(time)
    labels, out = [], []
    # the root: its spatial force in its own frame at its origin, to world axes about the
    # file's pelvis origin
    rot = np.column_stack([cols[c] for c in cmap.root.rotation])
    axes_t = np.array([_axis(a) for a in cmap.root.translation_axes])
    offset = np.array(cmap.root.offset)
    forces, moments = np.zeros((n, 3)), np.zeros((n, 3))
    for i in range(n):
        R = pin.Quaternion(q[i, 3:7]).normalized().toRotationMatrix()
        F, M = R @ tau[i, :3], R @ tau[i, 3:6]
        M = M + np.cross(R @ offset, F)  # about the file's pelvis origin
        forces[i] = axes_t @ F
        moments[i] = _sequence_axes(rot[i], cmap.root.rotation_axes) @ M
    labels += [f"{c}_moment" for c in cmap.root.rotation]
    labels += [f"{c}_force" for c in cmap.root.translation]
    out += [moments, forces]
    has = {j.joints[0] for j in cmap.extras if all(model.existJointName(x) for x in j.joints)}
    for jm in (*cmap.joints, *[j for j in cmap.extras if j.joints[0] in has]):
        if not all(model.existJointName(x) for x in jm.joints):
            continue
        j = model.getJointId(jm.joints[0])
        iv = model.joints[j].idx_v
        if jm.ball:
            values = np.column_stack([cols[c] for c in jm.columns])
            Q = np.zeros((n, 3))
            k = model.joints[j].idx_q
            for i in range(n):
                # the moment in the joint's frame on its parent (the sequence's frame)
                M = (
                    pin.Quaternion(q[i, k : k + 4]).normalized().toRotationMatrix()
                    @ tau[i, iv : iv + 3]
                )
                Q[i] = _sequence_axes(values[i], jm.axes) @ M
            out.append(Q)
        else:
            out.append(tau[:, iv : iv + 1] * jm.signs[0])
        labels += [f"{c}_moment" for c in jm.columns]
    return Table(np.asarray(time, dtype=float), labels, np.hstack(out), False, name)


def generalized_forces(h, q, table: Table, cmap: CoordinateMap | str = "rajagopal") -> np.ndarray:
    """The joints' generalised forces (n, nv) [N m] of a table of coordinate forces named as
    OpenSim's inverse dynamics names them (``hip_flexion_r_moment``...), at the body's
    configurations ``q`` (n, nq) on the table's times: the inverse of
    :func:`generalized_forces_table` for every joint of ``cmap`` whose columns the table has
    (a ball joint's moment in its child frame from the moments about its sequence's three
    axes; a one-axis joint's, the column times the map's sign). NaN in the rows of the root
    and of the joints whose columns the table lacks."""
    from scipy.spatial.transform import Rotation

    model = h.model
    cmap = MAPS[cmap] if isinstance(cmap, str) else cmap
    n = len(table.time)
    q = np.asarray(q, dtype=float).reshape(n, model.nq)
    tau = np.full((n, model.nv), np.nan)

    def rotation(j):  # (n, 3, 3) a ball joint's rotations
        k = model.joints[j].idx_q
        return Rotation.from_quat(q[:, k : k + 4]).as_matrix()

    has = {j.joints[0] for j in cmap.extras if all(model.existJointName(x) for x in j.joints)}
    for jm in (*cmap.joints, *[j for j in cmap.extras if j.joints[0] in has]):
        labels = [f"{c}_moment" for c in jm.columns]
        if not all(model.existJointName(x) for x in jm.joints) or not all(
            x in table for x in labels
        ):
            continue
        ids = [model.getJointId(x) for x in jm.joints]
        iv = model.joints[ids[0]].idx_v  # (a split joint's moment is its first joint's)
        Q = np.column_stack([table.column(x) for x in labels])
        if not jm.ball:
            tau[:, iv] = Q[:, 0] / jm.signs[0]
            continue
        if "thoracic" in has and len(ids) > 1 and "thoracic" in jm.joints:
            ids = ids[:1]  # (as coordinates_table writes it)
        R = rotation(ids[0])
        whole = R
        for j in ids[1:]:
            whole = whole @ rotation(j)
        values = _angles(whole, jm.axes)  # (n, 3) the sequence's angles
        # the sequence's axes in its parent's frame, one per row (_sequence_axes, all at once)
        A, turned = np.zeros((n, 3, 3)), np.tile(np.eye(3), (n, 1, 1))
        for c, a in enumerate(jm.axes):
            axis = _axis(a)
            A[:, c] = turned @ axis
            turned = turned @ Rotation.from_rotvec(values[:, c : c + 1] * axis).as_matrix()
        M = np.linalg.solve(A, Q[:, :, None])  # the moment in the parent's frame
        tau[:, iv : iv + 3] = (np.swapaxes(R, 1, 2) @ M)[:, :, 0]
    return tau
