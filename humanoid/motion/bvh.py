"""BVH (Biovision hierarchy), the animation and vision standard: read as joint centres, write a
body's motion.

A BVH file is a skeleton (``HIERARCHY``: ``ROOT``/``JOINT`` with an ``OFFSET`` from the parent
and ``CHANNELS``; ``End Site`` leaves) and a motion (``MOTION``, ``Frames:``, ``Frame Time:``,
one row of channel values per frame, in the order the channels were declared, depth first).
A joint's transform is ``T(offset + position channels) R``, with ``R`` the product of the
rotation channels in their listed order (intrinsic: ``Zrotation Xrotation Yrotation`` is
``Rz Rx Ry``, degrees), as Blender's importer and Holden's parser read it; the world is Y up.

**Reading** (:func:`read_bvh`) runs the skeleton's forward kinematics and returns its joints'
positions as marker trajectories, named after the default marker set's joint centres where a
joint's name says which it is (``Hips`` the pelvis, ``LeftUpLeg``/``LeftHip`` the left hip,
``LeftLeg``/``LeftKnee`` the knee, ``LeftFoot``/``LeftAnkle`` the ankle, ``LeftToeBase`` the
toes, ``LeftArm`` the shoulder, ``LeftForeArm`` the elbow, ``LeftHand`` the wrist, ``Neck``,
``Head``; the others keep their names): inverse kinematics then fits the body to them, whatever
the skeleton's rest pose. BVH has no unit: the scale that makes the skeleton's rest height a
person's (metres, centimetres, inches or millimetres) is taken unless one is given.

**Writing** (:func:`write_bvh`) gives each joint of the body a BVH joint (the root's six
channels, three rotations for every other, ``Z X Y``), in centimetres, Y up.
"""

from __future__ import annotations

import math
import re
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
import pinocchio as pin

from .loads import OPENSIM_TO_OURS
from .markers import MarkerTrajectories
from .storage import MAX_RATE, MAX_VALUE, MotionFileError, is_number

__all__ = ["BvhJoint", "read_bvh", "write_bvh"]

_CHANNELS = {f"{a}{kind}" for a in "xyz" for kind in ("position", "rotation")}
_AXIS = {"x": np.array([1.0, 0, 0]), "y": np.array([0, 1.0, 0]), "z": np.array([0, 0, 1.0])}

# joint names -> the default marker set's joint centres (lower case, separators dropped)
_NAMES = [
    (r"^(hips?|pelvis|root|rootjoint)$", "pelvis"),
    (r"^(left|l)(upleg|hip|thigh|femur)$", "left_hip"),
    (r"^(right|r)(upleg|hip|thigh|femur)$", "right_hip"),
    (r"^(left|l)(leg|knee|shin|lowleg|tibia)$", "left_knee"),
    (r"^(right|r)(leg|knee|shin|lowleg|tibia)$", "right_knee"),
    (r"^(left|l)(foot|ankle|ankleflexion)$", "left_ankle"),
    (r"^(right|r)(foot|ankle|ankleflexion)$", "right_ankle"),
    (r"^(left|l)(toebase|toe|toes)$", "left_toes"),
    (r"^(right|r)(toebase|toe|toes)$", "right_toes"),
    (r"^(left|l)(arm|upperarm|humerus)$", "left_shoulder"),
    (r"^(right|r)(arm|upperarm|humerus)$", "right_shoulder"),
    (r"^(left|l)(forearm|elbow|lowerarm)$", "left_elbow"),
    (r"^(right|r)(forearm|elbow|lowerarm)$", "right_elbow"),
    (r"^(left|l)(hand|wrist|wristflexion)$", "left_wrist"),
    (r"^(right|r)(hand|wrist|wristflexion)$", "right_wrist"),
    (r"^neck$", "neck"),
    (r"^head$", "head"),
]


@dataclass
class BvhJoint:
    """A joint of a BVH skeleton: its name, parent (index or -1), offset, channels."""

    name: str
    parent: int
    offset: np.ndarray
    channels: list[str] = field(default_factory=list)
    end_site: np.ndarray | None = None


def _tokens(text: str):
    for line_number, line in enumerate(text.splitlines(), start=1):
        for token in line.replace("{", " { ").replace("}", " } ").split():
            yield line_number, token


def parse_bvh(path: str | Path) -> tuple[list[BvhJoint], float, np.ndarray]:
    """(joints, frame time [s], channel values (frames, channels)) of a BVH file.

    Raises:
        MotionFileError: naming the file and line: missing, no HIERARCHY or MOTION, a malformed
            joint, a frame row of the wrong length.
    """
    path = Path(path)
    try:
        text = path.read_text(encoding="utf-8", errors="replace")
    except FileNotFoundError:
        raise MotionFileError(f"BVH file not found: {path}") from None
    head, sep, motion = text.partition("MOTION")
    if not sep or "HIERARCHY" not in head:
        raise MotionFileError(f"{path}: not a BVH file (HIERARCHY ... MOTION)")
    joints = _hierarchy(path, head)
    frame_time, values = _motion(path, motion, joints)
    return joints, frame_time, values


def _hierarchy(path: Path, head: str) -> list[BvhJoint]:
    """The joints of a BVH file's HIERARCHY section (``head``: the text before MOTION)."""
    joints: list[BvhJoint] = []
    stack: list[int] = []
    tokens = list(_tokens(head))
    i = 0

    def expect(k):
        if k >= len(tokens):
            raise MotionFileError(f"{path}: the hierarchy ends early")
        return tokens[k]

    def numbers(k, n):
        try:
            return np.array([float(expect(k + j)[1]) for j in range(n)])
        except ValueError:
            line = expect(k)[0]
            raise MotionFileError(f"{path}:{line}: expected {n} numbers") from None

    pending_end = False
    while i < len(tokens):
        line, tok = tokens[i]
        if tok in ("ROOT", "JOINT"):
            if (tok == "ROOT") != (not joints):
                raise MotionFileError(f"{path}:{line}: {tok} {expect(i + 1)[1]}: the hierarchy "
                                      "has one ROOT, first, and JOINTs inside it")  # fmt: skip
            name = expect(i + 1)[1]
            joints.append(BvhJoint(name, stack[-1] if stack else -1, np.zeros(3)))
            i += 2
        elif tok == "End":
            pending_end = True
            i += 2  # "End Site"
        elif tok == "{":
            stack.append(-2 if pending_end else len(joints) - 1)
            i += 1
        elif tok == "}":
            if not stack:
                raise MotionFileError(f"{path}:{line}: unbalanced braces")
            popped = stack.pop()
            if popped == -2:
                pending_end = False
            i += 1
        elif tok in ("OFFSET", "CHANNELS") and not joints:
            raise MotionFileError(f"{path}:{line}: {tok} before any ROOT")
        elif tok == "OFFSET":
            values = numbers(i + 1, 3)
            if stack and stack[-1] == -2:
                joints[-1].end_site = values
            elif joints:
                joints[-1].offset = values
            i += 4
        elif tok == "CHANNELS":
            try:
                n = int(expect(i + 1)[1])
            except ValueError:
                raise MotionFileError(f"{path}:{line}: CHANNELS needs a count") from None
            if not 0 <= n <= 6:
                raise MotionFileError(f"{path}:{line}: CHANNELS {n}: a joint has 0 to 6")
            joints[-1].channels = [expect(i + 2 + j)[1].lower() for j in range(n)]
            unknown = [c for c in joints[-1].channels if c not in _CHANNELS]
            if unknown:
                raise MotionFileError(
                    f"{path}:{line}: {joints[-1].name}: unknown channel {unknown[0]!r} "
                    "(Xposition, Yposition, Zposition, Xrotation, Yrotation, Zrotation)"
                )
            i += 2 + n
        else:
            i += 1  # HIERARCHY and anything unknown
    if not joints:
        raise MotionFileError(f"{path}: no joints in the hierarchy")
    return joints


def _motion(path: Path, motion: str, joints: list[BvhJoint]) -> tuple[float, np.ndarray]:
    """(frame time [s], channel values (frames, channels)) of a BVH file's MOTION section."""
    lines = motion.strip().splitlines()
    frames, frame_time, start = None, None, 0
    for k, line in enumerate(lines):
        try:
            if line.lower().startswith("frames:"):
                frames = int(line.split(":")[1])
            elif line.lower().startswith("frame time:"):
                frame_time = float(line.split(":")[1])
                start = k + 1
                break
        except ValueError:
            raise MotionFileError(f"{path}: MOTION: {line.strip()!r} is not a number") from None
    if frames is None or frame_time is None:
        raise MotionFileError(f"{path}: MOTION needs 'Frames:' and 'Frame Time:'")
    if not 1.0 / MAX_RATE <= frame_time < math.inf:
        raise MotionFileError(
            f"{path}: 'Frame Time: {frame_time}' [s]: a positive, finite time of at least "
            f"{1.0 / MAX_RATE:g} s (a rate of at most {MAX_RATE:g} Hz)"
        )
    width = sum(len(j.channels) for j in joints)
    rows: list[list[float]] = []
    for line in lines[start:]:
        if not line.strip():
            continue
        cells = line.split()
        if len(cells) != width:
            raise MotionFileError(f"{path}: frame {len(rows) + 1}: {len(cells)} values for "
                                  f"{width} channels")  # fmt: skip
        try:
            rows.append([float(c) for c in cells])
        except ValueError:
            bad = next(c for c in cells if not is_number(c))
            raise MotionFileError(f"{path}: frame {len(rows) + 1}: not a number: {bad!r}") from None
    values = np.array(rows, dtype=float).reshape(len(rows), width)
    if not np.all(np.abs(values) <= MAX_VALUE):  # (also NaN and inf)
        i, c = np.argwhere(~(np.abs(values) <= MAX_VALUE))[0]
        raise MotionFileError(f"{path}: frame {i + 1}, channel {c + 1}: {values[i, c]} is not a "
                              f"finite number of at most {MAX_VALUE:g}")  # fmt: skip
    if len(rows) != frames:
        raise MotionFileError(f"{path}: 'Frames: {frames}' but {len(rows)} rows")
    return frame_time, values


def _positions(joints, values) -> np.ndarray:
    """Forward kinematics: (frames, joints, 3) positions in the file's units and axes."""
    n = len(values)
    out = np.zeros((n, len(joints), 3))
    rot = np.zeros((n, len(joints), 3, 3))
    col = 0
    for j, joint in enumerate(joints):
        R = np.tile(np.eye(3), (n, 1, 1))
        p = np.tile(joint.offset, (n, 1))
        for c in joint.channels:
            x = values[:, col]
            col += 1
            if c.endswith("position"):
                p = p + x[:, None] * _AXIS[c[0]]
            elif c.endswith("rotation"):
                R = R @ np.array([pin.exp3(_AXIS[c[0]] * math.radians(a)) for a in x])
        if joint.parent < 0:
            rot[:, j], out[:, j] = R, p
        else:
            Rp = rot[:, joint.parent]
            out[:, j] = out[:, joint.parent] + np.einsum("nij,nj->ni", Rp, p)
            rot[:, j] = Rp @ R
    return out


def _marker_name(name: str) -> str:
    key = re.sub(r"[^a-z]", "", name.lower().split(":")[-1])
    for pattern, marker in _NAMES:
        if re.match(pattern, key):
            return marker
    return name


def read_bvh(path: str | Path, scale: float | None = None, y_up: bool = True) -> MarkerTrajectories:
    """The joint centres of a BVH motion as marker trajectories (see the module docstring), in
    metres (``scale``: metres per file unit; default: told from the rest pose's height), our
    axes (the file Y up by default)."""
    joints, frame_time, values = parse_bvh(path)
    rest = _positions(joints, np.zeros((1, values.shape[1])))[0]
    if scale is None:
        height = float(np.ptp(rest[:, 1] if y_up else rest[:, 2]))
        if height <= 0.0:
            raise MotionFileError(f"{path}: the skeleton has no height: give its scale")
        # a rest pose's joints span about 0.85 of a stature: the unit that makes it 1.2-2.2 m
        scale = min((1.0, 0.01, 0.0254, 0.001), key=lambda s: abs(math.log(height * s / 1.5)))
    with np.errstate(over="ignore", invalid="ignore"):
        pos = _positions(joints, values) * scale
    if not np.all(np.isfinite(pos)):
        raise MotionFileError(
            f"{path}: the joints' positions overflow (a channel's value or an offset too "
            "large for a body)"
        )
    if y_up:
        pos = pos @ OPENSIM_TO_OURS.T
    names = [_marker_name(j.name) for j in joints]
    seen: set[str] = set()
    unique: list[str] = []
    for n in names:  # a name twice (two 'Head' joints...): the second keeps its own
        unique.append(n if n not in seen else f"{n}_{len(unique)}")
        seen.add(n)
    time = np.arange(len(values)) * frame_time
    return MarkerTrajectories(time, unique, pos, str(path))


def write_bvh(path: str | Path, h, time, q, scale: float = 100.0) -> Path:
    """Write a body's motion ``q`` (n, nq) at uniform ``time`` as BVH: one BVH joint per joint
    of the body (named as the body's), the root's position and every rotation as ``Z X Y``
    degrees, in centimetres (``scale`` file units per metre), Y up."""
    from scipy.spatial.transform import Rotation

    model = h.model
    q = np.atleast_2d(np.asarray(q, dtype=float))
    time = np.asarray(time, dtype=float)
    if len(time) > 1 and not np.allclose(np.diff(time), time[1] - time[0], rtol=1e-6):
        raise MotionFileError("write_bvh needs uniform times")
    C = OPENSIM_TO_OURS.T  # ours to Y up
    children: dict[int, list[int]] = {j: [] for j in range(model.njoints)}
    for j in range(2, model.njoints):
        children[model.parents[j]].append(j)
    lines = ["HIERARCHY"]

    def emit(j, depth):
        pad = "\t" * depth
        placement = model.jointPlacements[j]
        offset = C @ placement.translation * scale if j > 1 else np.zeros(3)
        kind = "ROOT" if j == 1 else "JOINT"
        lines.append(f"{pad}{kind} {model.names[j]}")
        lines.append(f"{pad}{{")
        lines.append(f"{pad}\tOFFSET {offset[0]:.6f} {offset[1]:.6f} {offset[2]:.6f}")
        channels = "Zrotation Xrotation Yrotation"
        if j == 1:
            channels = "Xposition Yposition Zposition " + channels
        lines.append(f"{pad}\tCHANNELS {6 if j == 1 else 3} {channels}")
        for c in children[j]:
            emit(c, depth + 1)
        if not children[j]:
            lines.extend([f"{pad}\tEnd Site", f"{pad}\t{{", f"{pad}\t\tOFFSET 0.0 0.0 0.0",
                          f"{pad}\t}}"])  # fmt: skip
        lines.append(f"{pad}}}")

    emit(1, 0)
    dt = float(time[1] - time[0]) if len(time) > 1 else 1.0 / 30.0
    lines += ["MOTION", f"Frames: {len(q)}", f"Frame Time: {dt:.9f}"]
    data = model.createData()
    depth_first = []

    def walk(j):
        depth_first.append(j)
        for c in children[j]:
            walk(c)

    walk(1)
    for qi in q:
        pin.forwardKinematics(model, data, qi)
        row = []
        for j in depth_first:
            parent = model.parents[j]
            R_local = (
                (data.oMi[parent].rotation.T @ data.oMi[j].rotation)
                if j > 1
                else (data.oMi[1].rotation)
            )
            if j == 1:
                row += list(C @ data.oMi[1].translation * scale)
            angles = Rotation.from_matrix(C @ R_local @ C.T).as_euler("ZXY", degrees=True)
            row += list(angles)
        lines.append(" ".join(f"{x:.9g}" for x in row))
    path = Path(path)
    path.write_text("\n".join(lines) + "\n", encoding="utf-8")
    return path
