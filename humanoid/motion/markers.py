"""Markers and keypoints: 3D points attached to the body's frames, and the files they come in.

A **marker set** names points fixed to frames of the body (``frame``, ``offset`` in that frame
[m], ``weight`` in inverse kinematics). :func:`default_markers` builds one for the toolkit's
bodies from their own geometry: the joint centres (``right_hip``, ``right_knee``,
``right_ankle``, ``right_shoulder``, ``right_elbow``, ``right_wrist``, their left twins,
``pelvis``, ``neck``, ``head``, and the feet's balls ``right_toes``, ``left_toes``) and the
landmarks of OpenSim's gait2354 marker set by their
names there (``R.ASIS``, ``V.Sacral``, ``R.Heel``, ``R.Toe.Tip``, ``R.Acromium``, ``Top.Head``
... : the markers of its example walking trial), placed at the body's proportions (a scale of
the body's hip width): where a lab puts a marker on a person is where a marker set says, and a
person is not the body, so every marker's residual is reported, never hidden. Marker sets are
read and written as TOML (:func:`read_markers`, :func:`write_markers`)::

    [markers."R.ASIS"]
    frame = "pelvis"
    offset = [0.071, -0.125, 0.066]
    weight = 1.0
    anatomical = true    # false: a cluster's marker, registered by inverse kinematics
    fixed = true         # optional: scaling to a static trial does not move it

The landmarks' places are data (``humanoid/data/markers/default.toml``, :data:`LANDMARKS`),
written for a 1.75 m male body and scaled by a body's hip width.

**Keypoints** of pose estimators are joint centres in a fixed order (:data:`KEYPOINT_LAYOUTS`:
COCO's 17, Human3.6M's 17 as VideoPose3D orders them, OpenPose's BODY_25 (with the feet's toes
and heels), HALPE's 26 (the same feet's points), SMPL's 24), each named as the marker of the
default set it is (or None: no point of the body). Joint centres alone do not fix a foot's
orientation nor a limb's twist: give the feet's points (BODY_25, HALPE 26) where there are
any. 2D keypoints from calibrated cameras: :mod:`humanoid.motion.cameras`.

**TRC** files (OpenSim's and Motion Analysis's marker trajectories, :func:`read_trc`): a
header of 5 lines (``PathFileType``, the keys ``DataRate CameraRate NumFrames NumMarkers Units
...`` and their values, ``Frame# Time`` and the marker names, ``X1 Y1 Z1 ...``), then one
row per frame; empty fields or ``nan`` are a missing marker; Y up, turned to ours (z up);
millimetres or metres by ``Units``.
"""

from __future__ import annotations

import math
import warnings
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import pinocchio as pin

from ..errors import KeypointError, MarkerSetError
from .loads import OPENSIM_TO_OURS
from .storage import MAX_RATE, MotionFileError, check_rate, read_toml

__all__ = [
    "KEYPOINT_LAYOUTS",
    "LANDMARKS",
    "Marker",
    "MarkerTrajectories",
    "default_markers",
    "keypoints",
    "landmark_names",
    "marker_positions",
    "read_c3d",
    "read_markers",
    "read_trc",
    "write_markers",
    "write_trc",
]


# [m] the farthest a measured point may be from the lab's origin: no capture volume is a
# kilometre across; a coordinate beyond is corrupt (a TRC value of 1e300 made inverse
# kinematics never return)
MAX_POSITION = 1e3


@dataclass(frozen=True)
class Marker:
    """A point fixed to a frame of the body: ``offset`` [m] in the frame, its IK ``weight``;
    ``anatomical``: on a landmark the set places by anatomy (else a technical marker, a
    cluster's, whose place on the person is the lab's choice: inverse kinematics can register
    it, :func:`~humanoid.motion.ik.inverse_kinematics`); ``fixed``: scaling to a static trial
    leaves it where the set says (OpenSim's marker ``fixed``; else it is moved onto the
    trial's, :func:`~humanoid.motion.scale.scale_body`)."""

    frame: str
    offset: tuple[float, float, float] = (0.0, 0.0, 0.0)
    weight: float = 1.0
    anatomical: bool = True
    fixed: bool = False


@dataclass
class MarkerTrajectories:
    """Measured points over time, world axes (ours, z up) [m].

    Attributes:
        time: (n,) [s]. names: (m,). positions: (n, m, 3), NaN where a marker was not seen.
        source: Where they came from.
    """

    time: np.ndarray
    names: list[str]
    positions: np.ndarray
    source: str = ""

    def __post_init__(self) -> None:
        """Raises MotionFileError naming the source: times not finite, not increasing or
        closer than 1 / :data:`~humanoid.motion.storage.MAX_RATE`; positions not (n, m, 3);
        a coordinate infinite or beyond :data:`MAX_POSITION` (NaN is a missing marker)."""
        where = self.source or "markers"
        try:
            self.time = np.asarray(self.time, dtype=float).reshape(-1)
            positions = np.asarray(self.positions, dtype=float)
        except (TypeError, ValueError) as exc:
            raise MotionFileError(f"{where}: times and positions must be numbers: {exc}") from None
        self.names = list(self.names)
        shape = (len(self.time), len(self.names), 3)
        if positions.size != np.prod(shape):
            raise MotionFileError(
                f"{where}: {len(self.time)} times and {len(self.names)} markers need positions "
                f"of shape {shape}, got {positions.shape}"
            )
        self.positions = positions.reshape(shape)
        bad = ~np.isfinite(self.time)
        if bad.any():
            i = int(np.flatnonzero(bad)[0])
            raise MotionFileError(f"{where}: time of frame {i + 1} is {self.time[i]}")
        step = np.diff(self.time)
        if (step <= 0.0).any():
            i = int(np.flatnonzero(step <= 0.0)[0])
            raise MotionFileError(
                f"{where}: time does not increase at frame {i + 2} ({self.time[i]:g} then "
                f"{self.time[i + 1]:g} s)"
            )
        check_rate(self.time, where)
        far = np.isinf(self.positions) | (np.abs(np.nan_to_num(self.positions)) > MAX_POSITION)
        if far.any():
            i, k, _ = np.argwhere(far)[0]
            raise MotionFileError(
                f"{where}: marker {self.names[k]!r} at frame {i + 1} is at "
                f"{self.positions[i, k].tolist()} m: beyond {MAX_POSITION:g} m, not a place in "
                "a lab (a corrupt value, or the wrong unit)"
            )

    @property
    def rate(self) -> float:
        return (
            (len(self.time) - 1) / float(self.time[-1] - self.time[0])
            if len(self.time) > 1
            else math.nan
        )


# -- the toolkit's bodies' marker set ------------------------------------------------------

_SIDE = {"R": "right", "L": "left"}
_JOINTS = {"hip": "hip", "knee": "knee", "ankle": "ankle_flexion", "shoulder": "shoulder",
           "elbow": "elbow", "wrist": "wrist_flexion"}  # fmt: skip
# the frames the default marker set is placed on: a toolkit body's (humanoid build)
_DEFAULT_FRAMES = ["pelvis", "thorax", "head", "neck"] + [
    f"{s}_{x}" for s in ("left", "right")
    for x in ("hip", "knee", "ankle_flexion", "shoulder", "elbow", "wrist_flexion", "thigh",
              "shank", "foot", "upper_arm", "forearm", "hand", "sole")
]  # fmt: skip
LANDMARKS = Path(__file__).resolve().parent.parent / "data" / "markers" / "default.toml"


def _body_frame(model, side: str, segment: str) -> str:
    if segment in ("pelvis", "thorax", "head", "abdomen"):
        return segment
    if segment == "toes" and not model.existFrame(f"{side}_toes"):
        return f"{side}_foot"  # a one-piece foot carries its toe markers
    return f"{side}_{segment}"


def _landmarks(path: Path) -> tuple[str, dict]:
    """(the sided markers' name format, the landmarks) of a landmark file, checked.

    Raises:
        MarkerSetError: bad TOML, no ``[landmarks.NAME]`` tables, a landmark without a frame,
            a ``from`` or an offset, or with ``sides`` not true, false, "left" or "right".
    """
    spec = read_toml(path, "landmark set")
    table, names = spec.get("landmarks"), spec.get("names", "{side}.{name}")
    if not isinstance(table, dict) or not table:
        raise MarkerSetError(f"{path}: no [landmarks.NAME] tables")
    if not isinstance(names, str) or "{side}" not in names or "{name}" not in names:
        raise MarkerSetError(
            f"{path}: names must be a format with {{side}} and {{name}}, as "
            f'"{{side}}{{name}}" (RASI) or "{{side}}.{{name}}" (R.ASIS)'
        )
    for key, m in table.items():
        try:
            ok = (isinstance(m["frame"], str) and isinstance(m["from"], str)
                  and len([float(x) for x in m["offset"]]) == 3
                  and all(math.isfinite(float(x)) for x in m["offset"])
                  and isinstance(m.get("name", ""), str)
                  and (isinstance(m.get("sides", False), bool)
                       or m.get("sides") in ("left", "right")))  # fmt: skip
        except (KeyError, TypeError, ValueError, AttributeError):
            ok = False
        if ok:
            flag(path, f"landmarks.{key}", m, "anatomical", True)
        if not ok:
            raise MarkerSetError(
                f"{path}: landmarks.{key} needs a frame, a from, an offset of 3 "
                'numbers, and sides true, false, "left" or "right"'
            )
    return names, table


def landmark_names(path: str | Path = LANDMARKS) -> list[str]:
    """The markers' names of a landmark file (without the joint centres every set has)."""
    names, table = _landmarks(Path(path))
    out = []
    for key, spec in table.items():
        name, sides = spec.get("name", key), spec.get("sides", False)
        if sides is False:
            out.append(name)
            continue
        for letter, s in _SIDE.items():
            if sides is True or sides == s:
                out.append(names.format(side=letter, name=name))
    return out


class _Placer:
    """Markers placed on a body standing: points of the world [m] as offsets in its frames."""

    def __init__(self, h, path: Path):
        self.model, self.path = h.model, path
        self.data = self.model.createData()
        q0 = h.standing_configuration()
        pin.framesForwardKinematics(self.model, self.data, q0)
        self.out: dict[str, Marker] = {}

    def at(self, name):
        """The placement of frame ``name`` in the standing pose."""
        if not self.model.existFrame(name):
            raise MarkerSetError(
                f"{self.path}: no point {name!r} to place a landmark from (hip, knee, "
                "ankle, shoulder, elbow, wrist, neck, root, heel, toe)"
            )
        return self.data.oMf[self.model.getFrameId(name)]

    def attach(self, marker, frame, world, weight=1.0, anatomical=True):
        """Marker ``marker`` on ``frame``, at the point ``world`` of the standing pose."""
        if not self.model.existFrame(frame):
            raise MarkerSetError(f"{self.path}: {marker}: the body has no frame {frame!r} "
                                 "(pelvis, thigh, shank, foot, toes, thorax, upper_arm, "
                                 "forearm, hand, head)")  # fmt: skip
        offset = self.at(frame).actInv(np.asarray(world, dtype=float))
        self.out[marker] = Marker(frame, tuple(float(x) for x in offset), weight, anatomical)


def _place_sided(h, placer: _Placer, table: dict, names: str, scale: float) -> None:
    """Each side's toes marker and its landmarks of ``table`` (those with ``sides``)."""
    model = h.model
    at, attach = placer.at, placer.attach
    sole = {s: (h.sole_points(s), at(h.model.frames[h.sole_id(s)].name)) for s in ("left", "right")}
    for letter, s in _SIDE.items():
        mirror = 1.0 if s == "left" else -1.0
        points, M = sole[s]
        # the sole's middle line, at its back and front ends
        ends = []
        for k in (points[:, 0].argmin(), points[:, 0].argmax()):
            end = M.act(points[k])
            end[1] = M.translation[1]
            ends.append(end)
        heel, toe = ends
        attach(f"{s}_toes", f"{s}_foot", toe + np.array([-0.06, 0.0, 0.02]) * scale)
        centre = {"root": at("pelvis").translation, "heel": heel, "toe": toe}
        for key, spec in table.items():
            if spec.get("sides", False) not in (True, s):
                continue
            joint = spec["from"]
            origin = centre.get(joint)
            if origin is None:
                origin = at(f"{s}_{_JOINTS[joint]}" if joint in _JOINTS else joint).translation
            d = np.array(spec["offset"]) * scale * np.array([1.0, mirror, 1.0])
            marker = names.format(side=letter, name=spec.get("name", key))
            attach(marker, _body_frame(model, s, spec["frame"]), origin + d,
                   anatomical=spec.get("anatomical", True))  # fmt: skip


def default_markers(h, landmarks: str | Path = LANDMARKS) -> dict[str, Marker]:
    """The default marker set of a toolkit body (see the module docstring), or another set of
    landmarks written as ``default.toml`` is (``landmarks``: its file, as
    ``data/markers/plugin_gait.toml``; its optional ``names`` the sided markers' name format,
    default ``"{side}.{name}"``; a landmark's ``sides`` true, false, or ``"left"`` or
    ``"right"`` for one side's marker only; its ``name`` if not its key).

    Raises:
        MarkerSetError: the body is not one of the toolkit's (its frames have other names); a
            landmark file that cannot be read (naming it and the landmark).
    """
    model = h.model
    missing = [n for n in _DEFAULT_FRAMES if not model.existFrame(n)]
    if missing:
        raise MarkerSetError(
            f"{h.source}: the default marker set is for the toolkit's bodies (humanoid build); "
            f"this body has no {', '.join(missing[:5])}: give a marker set (TOML)"
        )
    path = Path(landmarks)
    names, table = _landmarks(path)
    placer = _Placer(h, path)
    at, attach, out = placer.at, placer.attach, placer.out
    scale = abs(at("left_hip").translation[1] - at("right_hip").translation[1]) / 0.16
    out["pelvis"] = Marker("pelvis", (0.0, 0.0, 0.0))
    for s in ("left", "right"):
        for name, joint in _JOINTS.items():
            attach(f"{s}_{name}", f"{s}_{joint}", at(f"{s}_{joint}").translation)
    attach("neck", "neck", at("neck").translation)
    attach("head", "head", at("neck").translation + np.array([0.0, 0.0, 0.12]) * scale)
    _place_sided(h, placer, table, names, scale)
    for key, spec in table.items():
        if spec.get("sides", False) is not False:
            continue
        joint = spec["from"]
        origin = at("pelvis").translation if joint == "root" else at(joint).translation
        attach(spec.get("name", key), spec["frame"], origin + np.array(spec["offset"]) * scale,
               anatomical=spec.get("anatomical", True))  # fmt: skip
    return out


def marker_positions(h, q: np.ndarray, markers: dict[str, Marker], names=None) -> np.ndarray:
    """Where the markers are for configurations ``q`` (n, nq): (n, m, 3) world [m], in the
    order of ``names`` (default: the set's)."""
    model = h.model
    data = model.createData()
    names = list(names or markers)
    q = np.atleast_2d(q)
    missing = sorted({markers[n].frame for n in names} - {f.name for f in model.frames})
    if missing:
        raise MarkerSetError(f"the marker set puts markers on {', '.join(map(repr, missing))}, "
                             f"which {h.source} does not have")  # fmt: skip
    ids = [model.getFrameId(markers[n].frame) for n in names]
    offsets = np.array([markers[n].offset for n in names])
    out = np.zeros((len(q), len(names), 3))
    for i, qi in enumerate(q):
        pin.framesForwardKinematics(model, data, qi)
        for k, (f, o) in enumerate(zip(ids, offsets, strict=True)):
            out[i, k] = data.oMf[f].act(o)
    return out


def read_markers(path: str | Path) -> dict[str, Marker]:
    """A marker set from TOML (``[markers.NAME]`` tables: ``frame``, ``offset``, ``weight``,
    optional ``anatomical`` and ``fixed``).

    Raises:
        MarkerSetError: missing file, bad TOML, a marker without a frame, an offset that is not
            three numbers, a negative weight.
    """
    path = Path(path)
    spec = read_toml(path, "marker set")
    table = spec.get("markers")
    if not isinstance(table, dict) or not table:
        raise MarkerSetError(f"{path}: no [markers.NAME] tables")
    out = {}
    for name, m in table.items():
        try:
            offset = tuple(float(x) for x in m.get("offset", (0.0, 0.0, 0.0)))
            weight = float(m.get("weight", 1.0))
            frame = str(m["frame"])
        except (KeyError, TypeError, ValueError, AttributeError):
            raise MarkerSetError(
                f"{path}: markers.{name} needs a frame, an offset of 3 numbers and a weight"
            ) from None
        if len(offset) != 3 or not all(math.isfinite(x) for x in offset):
            raise MarkerSetError(f"{path}: markers.{name}: offset must be 3 finite numbers")
        if not 0.0 <= weight <= MAX_WEIGHT:
            raise MarkerSetError(f"{path}: markers.{name}: weight {weight:g} must be in "
                                 f"[0, {MAX_WEIGHT:g}]")  # fmt: skip
        flags = [flag(path, f"markers.{name}", m, k, d) for k, d in (("anatomical", True),
                                                                    ("fixed", False))]  # fmt: skip
        out[name] = Marker(frame, offset, weight, *flags)
    return out


# a marker's largest IK weight: the weights are relative (1 the default); a weight of inf made
# inverse kinematics never return, and above 1e6 one marker's residual swamps every other's
# to rounding
MAX_WEIGHT = 1e6


def flag(path, where: str, table: dict, key: str, default: bool) -> bool:
    """``table[key]`` if it is a TOML boolean (``default`` if absent); else HumanoidError
    naming the file and ``where.key`` (a string "false" is not false)."""
    value = table.get(key, default)
    if not isinstance(value, bool):
        raise MarkerSetError(
            f"{path}: {where}.{key} must be true or false (no quotes), got {value!r}"
        )
    return value


def write_markers(path: str | Path, markers: dict[str, Marker]) -> Path:
    """Write a marker set as TOML (read back by :func:`read_markers`, to the bit)."""
    path = Path(path)
    lines = []
    for name, m in markers.items():
        lines += [f'[markers."{name}"]', f'frame = "{m.frame}"',
                  "offset = [" + ", ".join(repr(float(x)) for x in m.offset) + "]",
                  f"weight = {float(m.weight)!r}",
                  f"anatomical = {'true' if m.anatomical else 'false'}"]  # fmt: skip
        lines += ["fixed = true", ""] if m.fixed else [""]
    path.write_text("\n".join(lines), encoding="utf-8")
    return path


# -- keypoints -----------------------------------------------------------------------------

# each layout's points in its order, as the default set's markers (None: not a point of the
# body); sources: COCO (mmpose's coco.py), Human3.6M 17 as VideoPose3D keeps them
# (h36m_dataset.py), OpenPose's BODY_25 (its output format documentation: the feet's big
# toe, small toe and heel, which fix the feet's orientation, as markerless pipelines such as
# Pose2Sim use them), HALPE 26 (AlphaPose's, RTMPose's body with feet: COCO's 17, then head
# top, neck, hip centre, big toes, small toes, heels; Pose2Sim's default), SMPL (smplx's
# joint_names.py)
KEYPOINT_LAYOUTS = {
    "coco17": (
        "head", None, None, None, None, "left_shoulder", "right_shoulder", "left_elbow",
        "right_elbow", "left_wrist", "right_wrist", "left_hip", "right_hip", "left_knee",
        "right_knee", "left_ankle", "right_ankle",
    ),
    "h36m17": (
        "pelvis", "right_hip", "right_knee", "right_ankle", "left_hip", "left_knee",
        "left_ankle", None, None, "neck", "head", "left_shoulder", "left_elbow", "left_wrist",
        "right_shoulder", "right_elbow", "right_wrist",
    ),
    "body25": (
        None, "neck", "right_shoulder", "right_elbow", "right_wrist", "left_shoulder",
        "left_elbow", "left_wrist", "pelvis", "right_hip", "right_knee", "right_ankle",
        "left_hip", "left_knee", "left_ankle", None, None, None, None, "L.Toe.Med", "L.Toe.Lat",
        "L.Heel", "R.Toe.Med", "R.Toe.Lat", "R.Heel",
    ),
    "halpe26": (
        "head", None, None, None, None, "left_shoulder", "right_shoulder", "left_elbow",
        "right_elbow", "left_wrist", "right_wrist", "left_hip", "right_hip", "left_knee",
        "right_knee", "left_ankle", "right_ankle", None, "neck", "pelvis", "L.Toe.Med",
        "R.Toe.Med", "L.Toe.Lat", "R.Toe.Lat", "L.Heel", "R.Heel",
    ),
    "smpl24": (
        "pelvis", "left_hip", "right_hip", None, "left_knee", "right_knee", None, "left_ankle",
        "right_ankle", None, None, None, "neck", None, None, "head", "left_shoulder",
        "right_shoulder", "left_elbow", "right_elbow", "left_wrist", "right_wrist", None, None,
    ),
}  # fmt: skip


def keypoints(
    time, points, layout: str, y_up: bool = False, source: str = ""
) -> MarkerTrajectories:
    """Pose-estimator keypoints (n, k, 3) [m] in a known ``layout`` as marker trajectories
    named after the default set's joint centres (points the body has no match for dropped).

    Raises:
        KeypointError: an unknown layout, or points whose count is not the layout's.
    """
    if layout not in KEYPOINT_LAYOUTS:
        raise KeypointError(
            f"unknown keypoint layout {layout!r}; known: {', '.join(KEYPOINT_LAYOUTS)}"
        )
    names = KEYPOINT_LAYOUTS[layout]
    try:
        points = np.asarray(points, dtype=float)
    except (TypeError, ValueError) as exc:
        raise KeypointError(f"{source or 'keypoints'}: the points are not numbers: {exc}") from None
    if points.ndim != 3 or points.shape[1:] != (len(names), 3):
        raise KeypointError(
            f"{layout} keypoints must be (frames, {len(names)}, 3), got {points.shape}"
        )
    if np.isinf(points).any():
        raise KeypointError(f"{source or 'keypoints'}: a point is infinite (NaN marks a "
                            "keypoint not seen)")  # fmt: skip
    keep = [i for i, n in enumerate(names) if n is not None]
    pts = points[:, keep]
    if y_up:
        pts = pts @ OPENSIM_TO_OURS.T
    return MarkerTrajectories(time, [n for n in names if n is not None], pts, source)


# -- C3D -----------------------------------------------------------------------------------


def read_c3d(path: str | Path, y_up: bool | None = None) -> MarkerTrajectories:
    """The marker trajectories of a C3D file (ezc3d): positions in metres (``POINT:UNITS``),
    missing points NaN, our axes. ``y_up``: the lab's vertical is its Y (OpenSim's, turned to
    ours) or its Z (most gait labs', kept); default: Y if the file's ``POINT:Y_SCREEN`` says
    ``+Y``, else Z.

    Raises:
        MotionFileError: a missing or unreadable file, no points.
    """
    from .c3d_file import open_c3d

    path = Path(path)
    if not path.exists():
        raise MotionFileError(f"marker file not found: {path}")
    c = open_c3d(path)
    point = c["parameters"]["POINT"]
    names = [str(x).strip() for x in point["LABELS"]["value"]]
    data = np.asarray(c["data"]["points"], dtype=float)  # (4, m, n)
    if data.shape[1] == 0 or data.shape[2] == 0:
        raise MotionFileError(f"{path}: no marker points")
    names = names[: data.shape[1]]
    said = list(point["UNITS"]["value"]) if "UNITS" in point else ["mm"]
    units = str(said[0]).strip().lower() if said else ""
    scale = {"mm": 1e-3, "m": 1.0, "cm": 1e-2}.get(units)
    if scale is None:
        raise MotionFileError(f"{path}: unknown POINT:UNITS {units!r} (mm, cm or m)")
    try:
        rate = float(np.ravel(point["RATE"]["value"])[0])
    except (KeyError, IndexError, TypeError, ValueError):
        raise MotionFileError(f"{path}: no POINT:RATE (the frame rate [Hz])") from None
    if not 0.0 < rate <= MAX_RATE:
        raise MotionFileError(f"{path}: POINT:RATE {rate} Hz: give a rate in (0, {MAX_RATE:g}]")
    first = int(c["header"]["points"]["first_frame"])
    pos = np.transpose(data[:3], (2, 1, 0))  # (n, m, 3)
    check_units(path, pos, units, "POINT:UNITS")
    pos = pos * scale
    if y_up is None:
        screen = point.get("Y_SCREEN", {}).get("value", [""])
        y_up = str(screen[0]).strip().upper() == "+Y"
    if y_up:
        pos = pos @ OPENSIM_TO_OURS.T
    time = (first + np.arange(pos.shape[0])) / rate
    return MarkerTrajectories(time, names, pos, str(path))


_UNITS = {"mm": 1e-3, "cm": 1e-2, "m": 1.0}
# [m] the spread of a person's markers in one frame (the largest side of their bounding box,
# median over the frames): a standing or walking person's markers span about 1-2 m (2.5 m arms
# raised); a unit mistaken for another (mm, cm, m) moves it by 10x at least, out of these
# bounds (a TRC in millimetres labelled metres put the body 694 m up)
BODY_SPAN = (0.25, 10.0)
MIN_SPAN_MARKERS = 4  # a frame's spread is judged from at least this many markers seen


def check_units(path, positions: np.ndarray, units: str, key: str) -> None:
    """Raise MotionFileError naming the file and its unit ``key`` if ``positions`` (n, m, 3)
    in the file's ``units`` (mm, cm, m) do not span a person (:data:`BODY_SPAN`), saying which
    unit would; not judged with fewer than :data:`MIN_SPAN_MARKERS` markers in every frame."""
    seen = np.isfinite(positions).all(axis=2)
    frames = seen.sum(axis=1) >= MIN_SPAN_MARKERS
    if not frames.any():
        return
    p = positions[frames]
    with np.errstate(invalid="ignore"), warnings.catch_warnings():
        warnings.simplefilter("ignore", RuntimeWarning)
        sides = np.nanmax(p, axis=1) - np.nanmin(p, axis=1)
    span = float(np.median(sides.max(axis=1))) * _UNITS[units]
    low, high = BODY_SPAN
    if low <= span <= high:
        return
    fits = [u for u, s in _UNITS.items() if low <= span / _UNITS[units] * s <= high]
    hint = f"the numbers look like {fits[0]}: set {key} to {fits[0]}" if fits else "check it"
    raise MotionFileError(
        f"{path}: {key} says {units}, which spreads the markers over {span:.3g} m in a frame; a "
        f"person's span {low:g}-{high:g} m: {hint}"
    )


# -- TRC -----------------------------------------------------------------------------------


def read_trc(path: str | Path, y_up: bool = True) -> MarkerTrajectories:
    """Read a TRC file (see the module docstring); positions in metres, our axes.

    Raises:
        MotionFileError: naming the file and line: missing, not a TRC, a marker count that
            disagrees with the names, a row of the wrong length, an unknown unit.
    """
    path = Path(path)
    try:
        lines = path.read_text(encoding="utf-8", errors="replace").splitlines()
    except FileNotFoundError:
        raise MotionFileError(f"marker file not found: {path}") from None
    if len(lines) < 5 or not lines[0].startswith("PathFileType"):
        raise MotionFileError(f"{path}: not a TRC file (its first line must start PathFileType)")
    keys = [x for x in lines[1].split("\t") if x.strip()]
    values = [x.strip() for x in lines[2].split("\t") if x.strip()]
    if len(keys) != len(values):
        raise MotionFileError(f"{path}:3: {len(values)} values for {len(keys)} header keys")
    header = dict(zip([k.strip() for k in keys], values, strict=True))
    units = header.get("Units", "mm").lower()
    scale = _UNITS.get(units)
    if scale is None:
        raise MotionFileError(f"{path}: unknown Units {header.get('Units')!r} (mm, cm or m)")
    names = [x.strip() for x in lines[3].split("\t") if x.strip()][2:]
    if "NumMarkers" in header:
        try:
            count = int(header["NumMarkers"])
        except ValueError:
            raise MotionFileError(
                f"{path}:3: NumMarkers={header['NumMarkers']!r} is not a whole number"
            ) from None
        if count != len(names):
            raise MotionFileError(f"{path}:4: {len(names)} marker names for NumMarkers={count}")
    times: list[float] = []
    rows: list[list[float]] = []
    for number, line in enumerate(lines[5:], start=6):
        if not line.strip():
            if rows:
                break  # an empty line after the data ends it
            continue
        cells = [c.strip() for c in line.rstrip("\r\n").split("\t")]
        while len(cells) > 2 + 3 * len(names) and cells[-1] == "":
            cells.pop()
        if len(cells) < 2 + 3 * len(names):
            cells += [""] * (2 + 3 * len(names) - len(cells))
        if len(cells) != 2 + 3 * len(names):
            raise MotionFileError(
                f"{path}:{number}: {len(cells) - 2} coordinates for {len(names)} markers"
            )
        try:
            times.append(float(cells[1]))
            rows.append([float(c) if c else math.nan for c in cells[2:]])
        except ValueError:
            raise MotionFileError(f"{path}:{number}: not a number in {line[:60]!r}") from None
        if not math.isfinite(times[-1]) or np.isinf(rows[-1]).any():
            raise MotionFileError(f"{path}:{number}: time or a coordinate is not finite (a "
                                  "missing marker's fields are empty or nan)")  # fmt: skip
    if not rows:
        raise MotionFileError(f"{path}: no frames")
    pos = np.array(rows).reshape(len(rows), len(names), 3)
    check_units(path, pos, units, "Units")
    pos = pos * scale
    if y_up:
        pos = pos @ OPENSIM_TO_OURS.T
    return MarkerTrajectories(np.array(times), names, pos, str(path))


def write_trc(path: str | Path, markers: MarkerTrajectories, y_up: bool = True) -> Path:
    """Write marker trajectories as a TRC file (millimetres, OpenSim's Y up by default; a
    missing marker's fields empty)."""
    path = Path(path)
    n, m = len(markers.time), len(markers.names)
    rate = markers.rate if n > 1 else 1.0
    pos = markers.positions @ OPENSIM_TO_OURS if y_up else markers.positions
    lines = [
        f"PathFileType\t4\t(X/Y/Z)\t{path.name}",
        "DataRate\tCameraRate\tNumFrames\tNumMarkers\tUnits\tOrigDataRate\tOrigDataStartFrame"
        "\tOrigNumFrames",
        f"{rate:.6g}\t{rate:.6g}\t{n}\t{m}\tmm\t{rate:.6g}\t1\t{n}",
        "Frame#\tTime\t" + "\t\t\t".join(markers.names) + "\t\t",
        "\t\t" + "\t".join(f"X{i}\tY{i}\tZ{i}" for i in range(1, m + 1)),
        "",
    ]
    for i in range(n):
        cells = [str(i + 1), repr(float(markers.time[i]))]
        for p in pos[i] * 1000.0:
            cells += ["" if not np.isfinite(x) else repr(float(x)) for x in p]
        lines.append("\t".join(cells))
    path.write_text("\n".join(lines) + "\n", encoding="utf-8")
    return path
