"""Calibrated cameras and the 2D keypoints they see: markerless motion from several views.

A **camera** is OpenCV's pinhole model with its lens distortion: a world point ``P`` [m] is
``x = R P + t`` in the camera's frame (x right, y down, z along the view), ``(a, b) = (x/z,
y/z)`` on the normalised image plane, distorted by ``radial = 1 + k1 r^2 + k2 r^4 + k3 r^6``
(``r^2 = a^2 + b^2``) and the tangential terms ``p1, p2``::

    a' = a radial + 2 p1 a b + p2 (r^2 + 2 a^2)
    b' = b radial + p1 (r^2 + 2 b^2) + 2 p2 a b
    u = fx a' + cx,   v = fy b' + cy        [px]

Calibrations are read from Pose2Sim's TOML (:func:`read_calibration`; the format of its
``Calib_*.toml``, which Anipose and OpenCV's tools also write): one table per camera with
``name``, ``size`` (width, height [px]), ``matrix`` (3x3), ``distortions`` (k1, k2, p1, p2
and optionally k3), ``rotation`` (a Rodrigues vector, world to camera), ``translation``
(world to camera [m]) and ``fisheye`` (only ``false`` is supported); tables named
``metadata``, ``capture_volume``, ``charuco`` and ``checkerboard`` are not cameras. The
calibration's world is Z up, as ours.

**2D keypoints** (:class:`CameraKeypoints`) are a pose estimator's points in each camera's
images with their confidence, in a known layout (:data:`~humanoid.motion.markers.KEYPOINT_LAYOUTS`:
COCO 17, HALPE 26, BODY_25, ...). OpenPose's JSON (one file per frame, ``people[k].
pose_keypoints_2d`` = ``x, y, c`` per point) is read per camera folder as Pose2Sim lays them
out (:func:`read_openpose`: a ``pose`` folder of ``*_json`` folders, sorted by their last
number and matched to the calibration's cameras in its order). A point of confidence 0 (or
below ``threshold``) is not seen. With several people in a frame, the most confident is kept
(and the frames where there were several are counted in a warning).

Inverse kinematics fits the body to these directly, by reprojection error
(:func:`humanoid.motion.ik.inverse_kinematics` given a :class:`CameraKeypoints` and
``cameras``); :func:`triangulate` gives the 3D points (weighted DLT, as Pose2Sim's) for a
start and for comparison.
"""

from __future__ import annotations

import json
import math
import re
import warnings
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from ..errors import CameraError, KeypointError
from .markers import KEYPOINT_LAYOUTS, MAX_POSITION, MarkerTrajectories
from .storage import MotionFileError, read_toml

__all__ = [
    "Camera",
    "CameraKeypoints",
    "CameraWarning",
    "camera_keypoints",
    "look_at",
    "match_cameras",
    "read_calibration",
    "read_openpose",
    "triangulate",
    "write_calibration",
    "write_openpose",
]

NOT_CAMERAS = ("metadata", "capture_volume", "charuco", "checkerboard")
OUTSIDE = 0.2  # a camera whose seen points fall outside its image this often does not match
INCONSISTENT = 20.0  # [px] triangulated points reprojected this far off: not the recording's


class CameraWarning(UserWarning):
    """Keypoints or a calibration that do not look like each other: points outside the
    images, a camera that saw nothing, several people in a frame."""


@dataclass(frozen=True)
class Camera:
    """One calibrated camera (OpenCV's conventions; see the module docstring).

    Attributes:
        name: Its name in the calibration. size: (width, height) [px].
        matrix: The 3x3 intrinsic matrix [px]. distortions: (k1, k2, p1, p2, k3).
        rotation: 3x3, world to camera. translation: (3,), world to camera [m].
    """

    name: str
    size: tuple[float, float]
    matrix: np.ndarray
    distortions: np.ndarray
    rotation: np.ndarray
    translation: np.ndarray

    @property
    def centre(self) -> np.ndarray:
        """The camera's optical centre in the world [m]."""
        return -self.rotation.T @ self.translation

    @property
    def focal(self) -> float:
        """The mean focal length [px]."""
        return 0.5 * float(self.matrix[0, 0] + self.matrix[1, 1])

    def depth(self, points: np.ndarray) -> np.ndarray:
        """Each world point's depth along the view [m] (negative: behind the camera)."""
        return np.asarray(points, dtype=float) @ self.rotation[2] + self.translation[2]

    def project(self, points: np.ndarray, jacobian: bool = False):
        """World points (..., 3) [m] to pixels (..., 2); with ``jacobian``, also d(u, v)/dP
        (..., 2, 3) [px/m]. Points behind the camera give NaN."""
        P = np.asarray(points, dtype=float)
        x = P @ self.rotation.T + self.translation
        z = np.where(x[..., 2] > 1e-9, x[..., 2], np.nan)
        a, b = x[..., 0] / z, x[..., 1] / z
        k1, k2, p1, p2, k3 = self.distortions
        r2 = a * a + b * b
        radial = 1.0 + r2 * (k1 + r2 * (k2 + r2 * k3))
        ad = a * radial + 2 * p1 * a * b + p2 * (r2 + 2 * a * a)
        bd = b * radial + p1 * (r2 + 2 * b * b) + 2 * p2 * a * b
        K = self.matrix
        uv = np.stack([K[0, 0] * ad + K[0, 1] * bd + K[0, 2], K[1, 1] * bd + K[1, 2]], axis=-1)
        if not jacobian:
            return uv
        g = k1 + r2 * (2 * k2 + 3 * k3 * r2)  # d radial / d r2
        D = np.empty((*a.shape, 2, 2))  # d(a', b') / d(a, b)
        D[..., 0, 0] = radial + 2 * g * a * a + 2 * p1 * b + 6 * p2 * a
        D[..., 0, 1] = 2 * g * a * b + 2 * p1 * a + 2 * p2 * b
        D[..., 1, 0] = 2 * g * a * b + 2 * p1 * a + 2 * p2 * b
        D[..., 1, 1] = radial + 2 * g * b * b + 6 * p1 * b + 2 * p2 * a
        N = np.zeros((*a.shape, 2, 3))  # d(a, b) / d x
        N[..., 0, 0] = N[..., 1, 1] = 1.0 / z
        N[..., 0, 2] = -a / z
        N[..., 1, 2] = -b / z
        return uv, K[:2, :2] @ D @ N @ self.rotation

    def normalised(self, uv: np.ndarray, iterations: int = 20) -> np.ndarray:
        """Pixels (..., 2) back to the normalised image plane (..., 2): the distortion undone
        by fixed-point iteration (as OpenCV's ``undistortPoints``)."""
        K = self.matrix
        uv = np.asarray(uv, dtype=float)
        bd = (uv[..., 1] - K[1, 2]) / K[1, 1]
        ad = (uv[..., 0] - K[0, 2] - K[0, 1] * bd) / K[0, 0]
        k1, k2, p1, p2, k3 = self.distortions
        a, b = ad.copy(), bd.copy()
        for _ in range(iterations):
            r2 = a * a + b * b
            radial = 1.0 + r2 * (k1 + r2 * (k2 + r2 * k3))
            a = (ad - 2 * p1 * a * b - p2 * (r2 + 2 * a * a)) / radial
            b = (bd - p1 * (r2 + 2 * b * b) - 2 * p2 * a * b) / radial
        return np.stack([a, b], axis=-1)


def _rodrigues(r: np.ndarray) -> np.ndarray:
    import pinocchio as pin

    return pin.exp3(np.asarray(r, dtype=float))


def look_at(name: str, eye, target, size=(1920, 1080), focal: float = 1400.0,
            distortions=(0.0, 0.0, 0.0, 0.0, 0.0)) -> Camera:  # fmt: skip
    """A camera at ``eye`` [m] looking at ``target`` [m], the world's z up in its image, its
    principal point at the image's centre (for tests and projected recordings)."""
    eye, target = np.asarray(eye, dtype=float), np.asarray(target, dtype=float)
    forward = target - eye
    forward /= np.linalg.norm(forward)
    right = np.cross(forward, [0.0, 0.0, 1.0])
    if np.linalg.norm(right) < 1e-9:
        raise CameraError(f"camera {name!r} looks straight up or down: give another target")
    right /= np.linalg.norm(right)
    down = np.cross(forward, right)
    R = np.array([right, down, forward])  # rows: the camera's axes in the world
    K = np.array([[focal, 0.0, size[0] / 2], [0.0, focal, size[1] / 2], [0.0, 0.0, 1.0]])
    return Camera(name, (float(size[0]), float(size[1])), K, _distortions(distortions, name),
                  R, -R @ eye)  # fmt: skip


# a calibration's largest pixel count or matrix entry [px] and distortion coefficient (the
# projection of a point 1 m away overflowed with a translation of 1e300 m)
MAX_PIXELS = 1e6
MAX_DISTORTION = 1e3


def _distortions(d, where: str) -> np.ndarray:
    d = np.asarray(d, dtype=float).reshape(-1)
    if len(d) not in (4, 5):
        raise MotionFileError(
            f"{where}: distortions must be (k1, k2, p1, p2) or (k1, k2, p1, p2, k3), "
            f"got {len(d)} values"
        )
    return np.concatenate([d, [0.0]]) if len(d) == 4 else d


def read_calibration(path: str | Path) -> list[Camera]:
    """The cameras of a Pose2Sim calibration TOML, in the file's order (module docstring).

    Raises:
        MotionFileError: no camera in the file, a field missing or malformed (named with its
            camera), a value beyond :data:`MAX_POSITION`, :data:`MAX_PIXELS` or
            :data:`MAX_DISTORTION`, a fisheye camera.
    """
    path = Path(path)
    doc = read_toml(path, "a camera calibration (TOML)")
    cams = []
    for key, table in doc.items():
        if key in NOT_CAMERAS or not isinstance(table, dict):
            continue
        where = f"{path} [{key}]"
        missing = [f for f in ("size", "matrix", "distortions", "rotation", "translation")
                   if f not in table]  # fmt: skip
        if missing:
            raise MotionFileError(f"{where}: no {', '.join(missing)}")
        if table.get("fisheye", False):
            raise MotionFileError(
                f"{where}: fisheye = true; only the pinhole model with OpenCV's radial and "
                f"tangential distortion is supported"
            )
        try:
            size = tuple(float(x) for x in table["size"])
            K = np.array(table["matrix"], dtype=float)
            R = _rodrigues(np.array(table["rotation"], dtype=float))
            t = np.array(table["translation"], dtype=float)
            dist = _distortions(table["distortions"], where)
        except (TypeError, ValueError) as exc:
            raise MotionFileError(f"{where}: a field is not numbers: {exc}") from None
        if len(size) != 2 or K.shape != (3, 3) or t.shape != (3,) or R.shape != (3, 3):
            raise MotionFileError(f"{where}: size must be 2 numbers, matrix 3x3, rotation and "
                                  f"translation 3 numbers each")  # fmt: skip
        values = np.concatenate([size, K.ravel(), R.ravel(), t, dist])
        if not np.all(np.isfinite(values)) or K[0, 0] <= 0 or K[1, 1] <= 0 or min(size) <= 0:
            raise MotionFileError(f"{where}: non-finite values, or a focal length or an image "
                                  f"size that is not positive")  # fmt: skip
        for field, x, most, unit in (("translation", t, MAX_POSITION, " m"),
                                     ("matrix", K, MAX_PIXELS, " px"),
                                     ("size", np.array(size), MAX_PIXELS, " px"),
                                     ("distortions", dist, MAX_DISTORTION, "")):  # fmt: skip
            if np.abs(x).max() > most:
                raise MotionFileError(f"{where}: {field} has {np.abs(x).max():g}{unit}, beyond "
                                      f"{most:g}{unit}: not a calibration")  # fmt: skip
        cams.append(Camera(str(table.get("name", key)), size, K, dist, R, t))
    if not cams:
        raise MotionFileError(f"{path}: no camera (a table with size, matrix, distortions, "
                              f"rotation, translation)")  # fmt: skip
    return cams


def write_calibration(path: str | Path, cameras: list[Camera]) -> Path:
    """Write cameras as a Pose2Sim calibration TOML (read back by :func:`read_calibration`)."""
    import pinocchio as pin

    def row(x) -> str:
        return "[ " + ", ".join(repr(float(v)) for v in x) + "]"

    lines = []
    for c in cameras:
        lines += [f"[{c.name}]", f'name = "{c.name}"', f"size = {row(c.size)}",
                  "matrix = [ " + ", ".join(row(r) for r in c.matrix) + "]",
                  f"distortions = {row(c.distortions)}",
                  f"rotation = {row(pin.log3(c.rotation))}",
                  f"translation = {row(c.translation)}", "fisheye = false", ""]  # fmt: skip
    lines += ["[metadata]", "adjusted = false", "error = 0.0", ""]
    path = Path(path)
    path.write_text("\n".join(lines), encoding="utf-8")
    return path


@dataclass
class CameraKeypoints:
    """2D keypoints of one person seen by several cameras.

    Attributes:
        time: (n,) [s]. names: the points, named as the default marker set's (a layout's
            points the body has no match for dropped). cameras: the cameras' names (folders).
        uv: (c, n, k, 2) pixels, NaN where a camera did not see the point.
        confidence: (c, n, k) in [0, 1], 0 where not seen. source: where they came from.
    """

    time: np.ndarray
    names: list[str]
    cameras: list[str]
    uv: np.ndarray
    confidence: np.ndarray
    source: str = ""

    def __post_init__(self) -> None:
        self.time = np.asarray(self.time, dtype=float)
        self.uv = np.asarray(self.uv, dtype=float)
        self.confidence = np.asarray(self.confidence, dtype=float)
        c, n, k = len(self.cameras), len(self.time), len(self.names)
        what = self.source or "keypoints"
        if self.uv.shape != (c, n, k, 2) or self.confidence.shape != (c, n, k):
            raise KeypointError(
                f"{what}: uv must be (cameras, frames, points, 2) = ({c}, {n}, {k}, 2) and "
                f"confidence ({c}, {n}, {k}); got {self.uv.shape} and {self.confidence.shape}"
            )
        if n and (not np.all(np.isfinite(self.time)) or np.any(np.diff(self.time) <= 0)):
            raise KeypointError(f"{what}: times must be finite and increasing")
        bad = ~np.isfinite(self.confidence) | (self.confidence < 0)
        self.confidence = np.where(bad, 0.0, np.minimum(self.confidence, 1.0))
        unseen = (self.confidence <= 0) | ~np.all(np.isfinite(self.uv), axis=-1)
        self.uv = np.where(unseen[..., None], np.nan, self.uv)
        self.confidence = np.where(unseen, 0.0, self.confidence)
        if n and not np.any(self.confidence > 0):
            raise KeypointError(f"{what}: every keypoint has confidence 0: nothing was seen")

    @property
    def rate(self) -> float:
        """Frames per second [Hz] (the median interval's)."""
        return 1.0 / float(np.median(np.diff(self.time))) if len(self.time) > 1 else 0.0


def camera_keypoints(time, uv, confidence, layout: str, cameras, source: str = "",
                     threshold: float = 0.0) -> CameraKeypoints:  # fmt: skip
    """Keypoints (c, n, len(layout), 2) [px] with their confidence (c, n, len(layout)) in a
    known ``layout``, named as the default marker set (points without a match dropped);
    points at or below ``threshold`` confidence are not seen."""
    if layout not in KEYPOINT_LAYOUTS:
        raise KeypointError(
            f"unknown keypoint layout {layout!r}; known: {', '.join(KEYPOINT_LAYOUTS)}"
        )
    names = KEYPOINT_LAYOUTS[layout]
    uv, conf = np.asarray(uv, dtype=float), np.asarray(confidence, dtype=float)
    if uv.ndim != 4 or uv.shape[2:] != (len(names), 2):
        raise KeypointError(f"{source or 'keypoints'}: {layout} keypoints must be (cameras, "
                            f"frames, {len(names)}, 2), got {uv.shape}")  # fmt: skip
    keep = [i for i, n in enumerate(names) if n is not None]
    conf = np.where(conf > threshold, conf, 0.0)
    return CameraKeypoints(time, [n for n in names if n is not None], list(cameras), uv[:, :, keep],
                           conf[:, :, keep], source)  # fmt: skip


def _last_number(p: Path) -> tuple:
    found = re.findall(r"\d+", p.name)
    return (int(found[-1]) if found else -1, p.name)


def _camera_folders(folder: Path) -> list[Path]:
    """A Pose2Sim ``pose`` folder's camera folders (``*json*``), by their last number; or the
    folder itself if it holds the JSON files."""
    if any(folder.glob("*.json")):
        return [folder]
    subs = sorted((p for p in folder.iterdir() if p.is_dir() and "json" in p.name),
                  key=_last_number)  # fmt: skip
    if not subs:
        raise MotionFileError(f"{folder}: no camera folder (a folder of OpenPose .json files "
                              f"per camera, named *_json)")  # fmt: skip
    return subs


def read_openpose(folder: str | Path, layout: str, rate: float, threshold: float = 0.0,
                  folders: list | None = None) -> CameraKeypoints:  # fmt: skip
    """OpenPose JSON keypoints of several cameras (module docstring): ``folder`` holds one
    folder of frames per camera (or give the camera ``folders`` in order); frame ``i`` is at
    ``i / rate`` [s].

    Raises:
        MotionFileError: no JSON, a file that is not OpenPose's, a point count that is not
            the layout's, cameras with different frame counts.
    """
    if not (math.isfinite(rate) and rate > 0):
        raise KeypointError(f"rate must be a positive number of frames per second, got {rate}")
    if layout not in KEYPOINT_LAYOUTS:
        raise KeypointError(
            f"unknown keypoint layout {layout!r}; known: {', '.join(KEYPOINT_LAYOUTS)}"
        )
    k = len(KEYPOINT_LAYOUTS[layout])
    cams = [Path(f) for f in folders] if folders else _camera_folders(Path(folder))
    per_camera, several = [], {}
    for cam in cams:
        files = sorted(cam.glob("*.json"), key=_last_number)
        if not files:
            raise MotionFileError(f"{cam}: no OpenPose .json file")
        frames, many = [], 0
        for f in files:
            try:
                people = json.loads(f.read_text(encoding="utf-8")).get("people", [])
                points = [np.asarray(p["pose_keypoints_2d"], dtype=float) for p in people]
            except (OSError, ValueError, TypeError, KeyError, AttributeError) as exc:
                raise MotionFileError(f"{f}: not OpenPose keypoints ({exc})") from None
            for p in points:
                if p.shape != (3 * k,):
                    raise MotionFileError(
                        f"{f}: pose_keypoints_2d has {p.size} values, {layout} needs "
                        f"{3 * k} (x, y, c per point)"
                    )
            many += len(points) > 1
            best = max(points, key=lambda p: float(np.nansum(p[2::3])), default=None)
            frames.append(np.full(3 * k, np.nan) if best is None else best)
        if many:
            several[cam.name] = many
        per_camera.append(np.array(frames).reshape(len(frames), k, 3))
    counts = {c.name: len(p) for c, p in zip(cams, per_camera, strict=True)}
    if len(set(counts.values())) > 1:
        raise MotionFileError(f"{folder}: the cameras have different frame counts "
                              f"({', '.join(f'{c} {n}' for c, n in counts.items())}): "
                              f"synchronise them first")  # fmt: skip
    if several:
        named = ", ".join(f"{c} ({n} frames)" for c, n in several.items())
        warnings.warn(f"{folder}: several people in {named}; the most confident person was "
                      f"kept in each frame", CameraWarning, stacklevel=2)  # fmt: skip
    data = np.array(per_camera)  # (c, n, k, 3)
    conf = np.nan_to_num(data[..., 2], nan=0.0)
    n = data.shape[1]
    return camera_keypoints(np.arange(n) / rate, data[..., :2], conf, layout,
                            [c.name for c in cams], str(folder), threshold)  # fmt: skip


def write_openpose(folder: str | Path, uv: np.ndarray, confidence: np.ndarray,
                   cameras: list[str]) -> list[Path]:  # fmt: skip
    """Write keypoints (c, n, k, 2) [px] and confidences (c, n, k) as OpenPose JSON, one
    ``<camera>_json`` folder per camera under ``folder`` (as Pose2Sim lays them out); a NaN
    point is written as 0, 0, 0."""
    out = []
    for c, name in enumerate(cameras):
        d = Path(folder) / f"{name}_json"
        d.mkdir(parents=True, exist_ok=True)
        for i in range(uv.shape[1]):
            xyc = np.concatenate([uv[c, i], confidence[c, i][:, None]], axis=1)
            xyc = np.where(np.isfinite(xyc).all(axis=1, keepdims=True), xyc, 0.0)
            person = {"person_id": [-1], "pose_keypoints_2d": [float(x) for x in xyc.ravel()]}
            (d / f"{name}_{i:06d}_keypoints.json").write_text(
                json.dumps({"version": 1.3, "people": [person]}), encoding="utf-8")  # fmt: skip
        out.append(d)
    return out


def match_cameras(keypoints: CameraKeypoints, cameras: list[Camera],
                  calibration: str = "the calibration") -> list[Camera]:  # fmt: skip
    """The calibration's cameras for the keypoints' views, in order (Pose2Sim's rule: the
    n-th camera folder is the calibration's n-th camera).

    Raises:
        CameraError: the counts differ.
    Warns:
        CameraWarning: a camera whose seen points fall outside its image in more than
            :data:`OUTSIDE` of them (the calibration is another's, or the order is wrong),
            or a camera that saw nothing.
    """
    if len(cameras) != len(keypoints.cameras):
        raise CameraError(
            f"{calibration} has {len(cameras)} cameras ({', '.join(c.name for c in cameras)}), "
            f"{keypoints.source or 'the keypoints'} {len(keypoints.cameras)} "
            f"({', '.join(keypoints.cameras)})"
        )
    for c, cam in enumerate(cameras):
        uv = keypoints.uv[c][keypoints.confidence[c] > 0]
        if not len(uv):
            warnings.warn(f"camera {keypoints.cameras[c]} ({cam.name}) saw no keypoint",
                          CameraWarning, stacklevel=2)  # fmt: skip
            continue
        w, h = cam.size
        out = np.mean((uv[:, 0] < 0) | (uv[:, 0] > w) | (uv[:, 1] < 0) | (uv[:, 1] > h))
        if out > OUTSIDE:
            warnings.warn(f"{keypoints.cameras[c]}: {out:.0%} of its keypoints fall outside "
                          f"{cam.name}'s {w:.0f}x{h:.0f} image: is {calibration} this "
                          f"recording's, its cameras in this order?", CameraWarning,
                          stacklevel=2)  # fmt: skip
    return list(cameras)


def triangulate(keypoints: CameraKeypoints, cameras: list[Camera],
                least: int = 2) -> MarkerTrajectories:  # fmt: skip
    """The 3D points [m] of the keypoints seen by at least ``least`` cameras (confidence-
    weighted DLT on the undistorted image points, Pose2Sim's), NaN elsewhere.

    Warns:
        CameraWarning: the points reprojected more than :data:`INCONSISTENT` px (median) from
            the keypoints: the calibration is not the recording's, or not in its order.
    """
    cams = match_cameras(keypoints, cameras)
    c, n, k = keypoints.confidence.shape
    rows = np.zeros((n, k, 2 * c, 4))
    for j, cam in enumerate(cams):
        ab = cam.normalised(keypoints.uv[j])  # (n, k, 2)
        P = np.hstack([cam.rotation, cam.translation[:, None]])
        w = keypoints.confidence[j][..., None]
        ok = w > 0
        for d in range(2):
            row = ab[..., d : d + 1] * P[2] - P[d]
            rows[:, :, 2 * j + d] = np.where(ok, w * np.nan_to_num(row), 0.0)
    seen = (keypoints.confidence > 0).sum(axis=0)
    _, _, vt = np.linalg.svd(rows)
    X = vt[..., -1, :]
    with np.errstate(invalid="ignore", divide="ignore"):
        pts = X[..., :3] / X[..., 3:4]
    pts[seen < least] = np.nan
    errors = [np.linalg.norm(cam.project(pts) - keypoints.uv[j], axis=-1)
              for j, cam in enumerate(cams)]  # fmt: skip
    typical = float(np.nanmedian(errors)) if np.isfinite(errors).any() else 0.0
    if typical > INCONSISTENT:
        warnings.warn(f"{keypoints.source or 'keypoints'}: the triangulated points' median "
                      f"reprojection error is {typical:.0f} px: are the cameras this "
                      f"recording's, in its order?", CameraWarning, stacklevel=2)  # fmt: skip
    return MarkerTrajectories(keypoints.time, list(keypoints.names), pts,
                              keypoints.source)  # fmt: skip
