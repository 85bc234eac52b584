"""One calibrated camera: what a single view needs that several do not.

Seen by one camera, a point's depth along its ray is not measured: the body's known segment
lengths and the perspective (a segment farther away looks shorter) are all that tell it, and a
limb turned towards the camera projects as the same limb turned away (a left/right or a
forward/backward flip). Inverse kinematics from one view
(:func:`~humanoid.motion.ik.inverse_kinematics` given one camera) therefore:

- **starts** from the standing body placed on the rays (:func:`place_on_rays`: its depth from
  its size in the image, then the translation that best reprojects it) at several headings, and
  keeps the heading that fits best (:data:`HEADINGS`);
- holds the feet on the **floor**: the calibration's world has its floor at z = 0, and a
  walking or standing person has a foot on it: the lowest sole point is pulled onto the plane
  and every sole point is kept out of it (:func:`floor_rows`; ``ground`` in the fit), which,
  seen by a camera above the floor, fixes the depth of the foot on it;
- reports what one view leaves open (:class:`DepthReport`): per frame, the standard deviation
  of the root's depth along the ray that the fit's own curvature gives for one pixel of noise,
  and the frames where it is large.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
import pinocchio as pin

from ..errors import HumanoidError
from ..model import SIDES

__all__ = [
    "DepthReport",
    "HEADINGS",
    "SingleViewWarning",
    "check_single_view",
    "floor_rows",
    "place_on_rays",
]

# the first frame's starting headings (about the vertical) tried from one view [rad]
HEADINGS = tuple(k * math.pi / 4 for k in range(8))
OFF = 10.0  # [px] a one-view fit reprojecting this far off (RMS) does not match its camera
LOW_CAMERA = 0.3  # [m] a camera this close to the floor's height sees the floor edge-on


class SingleViewWarning(UserWarning):
    """Keypoints from one camera: depth along its rays is weakly observed (said with numbers),
    or the camera sees the body in a way that leaves it unobserved."""


def place_on_rays(camera, uv: np.ndarray, points: np.ndarray,
                  iterations: int = 10) -> np.ndarray:  # fmt: skip
    """The translation [m] that puts the body's ``points`` (k, 3) [m] (a standing body's
    markers) where ``camera`` sees them at ``uv`` (k, 2) [px]: its depth first from its size in
    the image (the points' spread in metres over their spread on the normalised image), then
    Gauss-Newton on the reprojection error over the translation alone.

    Raises:
        HumanoidError: fewer than 3 points, or points that project onto one place.
    """
    ok = np.all(np.isfinite(uv), axis=1) & np.all(np.isfinite(points), axis=1)
    if ok.sum() < 3:
        raise HumanoidError(f"{camera.name}: fewer than 3 keypoints seen, cannot place the body")
    uv, points = uv[ok], points[ok]
    ab = camera.normalised(uv)
    spread_img = float(np.sqrt(np.mean(np.sum((ab - ab.mean(axis=0)) ** 2, axis=1))))
    spread_body = float(np.sqrt(np.mean(np.sum((points - points.mean(axis=0)) ** 2, axis=1))))
    if spread_img < 1e-9:
        raise HumanoidError(f"{camera.name}: the keypoints fall on one pixel, cannot place "
                            f"the body")  # fmt: skip
    depth = spread_body / spread_img
    a, b = ab.mean(axis=0)
    ray = camera.rotation.T @ np.array([a, b, 1.0])
    t = camera.centre + depth * ray - points.mean(axis=0)
    for _ in range(iterations):
        proj, J = camera.project(points + t, jacobian=True)
        if not np.all(np.isfinite(proj)):
            break
        r = (uv - proj).reshape(-1)
        J = J.reshape(-1, 3)
        dt = np.linalg.lstsq(J, r, rcond=None)[0]
        t = t + dt
        if np.abs(dt).max() < 1e-6:
            break
    return t


class SolePoints:
    """Both feet's sole points in the world and their Jacobians (for the floor's rows)."""

    def __init__(self, h) -> None:
        self.model = h.model
        self.frames = [h.sole_id(s) for s in SIDES]
        self.points = [h.sole_points(s) for s in SIDES]

    def __call__(self, data) -> tuple[np.ndarray, np.ndarray]:
        """Heights (s,) [m] and their Jacobians (s, nv), with ``data``'s joint Jacobians and
        frame placements up to date."""
        z, J = [], []
        for f, pts in zip(self.frames, self.points, strict=True):
            M = data.oMf[f]
            Jf = pin.getFrameJacobian(self.model, data, f, pin.LOCAL_WORLD_ALIGNED)
            for p in pts:
                world = M.act(p)
                z.append(world[2])
                J.append((Jf[:3] - pin.skew(world - M.translation) @ Jf[3:])[2])
        return np.array(z), np.array(J)


def floor_rows(z: np.ndarray, Jz: np.ndarray, weight: float):
    """The floor's rows (J, r, w) from the sole points' heights ``z`` [m] and Jacobians: the
    lowest point pulled onto z = 0 and every other point below it pushed out, at ``weight``."""
    low = int(np.argmin(z))
    rows = np.flatnonzero(z < 0.0)
    rows = np.union1d(rows, [low])
    return Jz[rows], -z[rows], np.full(len(rows), weight)


@dataclass(frozen=True)
class DepthReport:
    """How well one view saw the root's depth (a single-camera fit's
    :attr:`~humanoid.motion.ik.IKResult.depth`).

    Attributes:
        camera: The camera's name. sd: (n,) per frame, the standard deviation of the root's
            position along the ray through it [m], for one pixel of noise on every keypoint
            (from the fit's Gauss-Newton curvature, with the priors it had). across: (n,) the
            same across the ray (its largest direction) [m]. distance: (n,) the root's depth
            from the camera [m]. pixels: the fit's RMS reprojection error [px].
        threshold: frames with ``sd * pixels`` above this [m] are flagged (:attr:`weak`).
    """

    camera: str
    sd: np.ndarray
    across: np.ndarray
    distance: np.ndarray
    pixels: float
    threshold: float = 0.05

    @property
    def weak(self) -> np.ndarray:
        """The frames whose depth is uncertain by more than :attr:`threshold` at the fit's
        noise (the flagged frames)."""
        return self.sd * max(self.pixels, 1.0) > self.threshold

    def summary(self) -> str:
        """One line: the depth's uncertainty against the cross-ray's, the flagged frames."""
        k = max(self.pixels, 1.0) * 1e3
        return (f"one camera ({self.camera}, {np.median(self.distance):.1f} m away): depth along "
                f"its rays is weakly observed, the root's uncertain by "
                f"{np.median(self.sd) * k:.0f} mm (median; {np.median(self.across) * k:.0f} mm "
                f"across) at the "
                f"{self.pixels:.1f} px fit; {int(self.weak.sum())} of {len(self.sd)} frames "
                f"over {self.threshold * 1e3:.0f} mm")  # fmt: skip


def check_single_view(report: DepthReport, camera, ground: float) -> None:
    """Warn (:class:`SingleViewWarning`) where one view's fit cannot be trusted: it reprojects
    more than :data:`OFF` px off (the calibration is not the recording's: a wrong focal
    length or axis cannot be fitted with the feet on the floor), or the floor was used and the
    camera is within :data:`LOW_CAMERA` of its height (its rays meet the floor at a grazing
    angle: the feet do not fix the depth)."""
    import warnings

    if report.pixels > OFF:
        warnings.warn(f"one camera ({camera.name}): the fit reprojects {report.pixels:.0f} px "
                      f"off (RMS): is the calibration this recording's (its focal length, its "
                      f"axes, the floor at z = 0)?", SingleViewWarning, stacklevel=3)  # fmt: skip
    if ground and abs(float(camera.centre[2])) < LOW_CAMERA:
        warnings.warn(f"one camera ({camera.name}) {camera.centre[2]:.2f} m above the floor: "
                      f"its rays graze the floor, the feet on it do not fix the depth",
                      SingleViewWarning, stacklevel=3)  # fmt: skip
