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
- fits **twice** (``stances`` in the fit): a walking or standing person's foot on the floor
  does not slide, so the feet the first fit has planted (:func:`find_stances`: low and slow,
  with hysteresis, at least :data:`STANCE_SHORTEST` long) are held still in the second
  (:class:`StancePins`: each sole point on the floor pinned to its mean horizontal place over
  the stance), and the second runs backwards in time from the first's last frame: a fit
  solved forwards has no past to hold its first frames' depth, and on the 2-step walk seen
  from one camera those frames' depth wandered 10-20 cm, which tracking in forward simulation
  (:func:`~humanoid.motion.tracking.track`) could not follow (scripts/single_camera.py, side
  and 45-deg views, seeds 0-4: tracking completed 1 of 10 runs after the forward fit alone,
  9 of 10 after both passes; the pins alone, forwards: 0 of 5, 1 with three such passes;
  backwards unpinned: 9 of 10, the root 25-70 mm along the ray against 28-49 pinned);
- reports what one view leaves open (:class:`DepthReport`): per frame, the standard deviation
  of the root's depth along the ray that the fit's own curvature gives for one pixel of noise,
  and the frames where it is large.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
import pinocchio as pin

from ..errors import IKError
from ..model import SIDES

__all__ = [
    "DepthReport",
    "HEADINGS",
    "SingleViewWarning",
    "Stance",
    "StancePins",
    "check_single_view",
    "find_stances",
    "floor_rows",
    "place_on_rays",
    "sole_world",
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
        IKError: fewer than 3 points, or points that project onto one place.
    """
    ok = np.all(np.isfinite(uv), axis=1) & np.all(np.isfinite(points), axis=1)
    if ok.sum() < 3:
        raise IKError(f"{camera.name}: fewer than 3 keypoints seen, cannot place the body")
    uv, points = uv[ok], points[ok]
    ab = camera.normalised(uv)
    spread_img = float(np.sqrt(np.mean(np.sum((ab - ab.mean(axis=0)) ** 2, axis=1))))
    spread_body = float(np.sqrt(np.mean(np.sum((points - points.mean(axis=0)) ** 2, axis=1))))
    if spread_img < 1e-9:
        raise IKError(f"{camera.name}: the keypoints fall on one pixel, cannot place "
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
        stances: The planted feet held still by the fit's second pass (:class:`Stance`;
            None: no second pass, as with ``stances=False`` or without the floor).
    """

    camera: str
    sd: np.ndarray
    across: np.ndarray
    distance: np.ndarray
    pixels: float
    threshold: float = 0.05
    stances: tuple | None = None

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
                f"over {self.threshold * 1e3:.0f} mm{self._stances()}")  # fmt: skip

    def _stances(self) -> str:
        """The second pass's clause of :meth:`summary` (empty without one)."""
        if self.stances is None:
            return ""
        if not self.stances:
            return "; solved again backwards, no foot planted on the floor to hold still"
        sides = {s: sum(x.side == s for x in self.stances) for s in SIDES}
        worst = max(x.slide for x in self.stances)
        return (f"; solved again backwards with {len(self.stances)} stances held still "
                f"({sides['left']} left, {sides['right']} right; the first fit slid a planted "
                f"foot up to {worst * 1e3:.0f} mm)")  # fmt: skip


def check_single_view(report: DepthReport, camera, ground: float, stacklevel: int = 3) -> None:
    """Warn (:class:`SingleViewWarning`) where one view's fit cannot be trusted: it reprojects
    more than :data:`OFF` px off (the calibration is not the recording's: a wrong focal
    length or axis cannot be fitted with the feet on the floor), or the floor was used and the
    camera is within :data:`LOW_CAMERA` of its height (its rays meet the floor at a grazing
    angle: the feet do not fix the depth). ``stacklevel``: the warnings', from here."""
    import warnings

    if report.pixels > OFF:
        warnings.warn(f"one camera ({camera.name}): the fit reprojects {report.pixels:.0f} px "
                      f"off (RMS): is the calibration this recording's (its focal length, its "
                      f"axes, the floor at z = 0)?", SingleViewWarning,
                      stacklevel=stacklevel)  # fmt: skip
    if ground and abs(float(camera.centre[2])) < LOW_CAMERA:
        warnings.warn(f"one camera ({camera.name}) {camera.centre[2]:.2f} m above the floor: "
                      f"its rays graze the floor, the feet on it do not fix the depth",
                      SingleViewWarning, stacklevel=stacklevel)  # fmt: skip


# Stances (:func:`find_stances`): a walking or standing person's foot on the floor does not
# slide, so from one view a planted foot's place fixes the depth that its noise leaves free.
# [m] a foot is planted when its lowest sole point comes this close to the floor z = 0 (the
# floor's rows hold a planted one within mm; the walk's swinging foot clears it by 1.5 cm or
# more, but is fast then) ...
STANCE_LOW = 0.01
# [m] ... and stays planted while that point is within this of it (hysteresis: a fit's sole
# lifts a centimetre off the floor with its noise)
STANCE_HIGH = 0.03
# [m/s] ... and its lowest sole point moves horizontally slower than this (the walk's
# swinging foot: 2-3 m/s; a planted foot's fit from 3 px at 30 Hz: up to 0.4 m/s of noise) ...
STANCE_SLOW = 0.5
# [m/s] ... staying planted while slower than this
STANCE_FAST = 1.0
STANCE_SHORTEST = 0.1  # [s] planted runs shorter than this are none (a walk's stance: 0.6 s)
# [m] in a stance, a sole point this close to the floor is on it (its horizontal place pinned)
POINT_LOW = 0.015
# the pinned points' pull onto their places, per marker weight (as stiff as the floor's
# :data:`~humanoid.motion.ik.SINGLE_VIEW_GROUND`)
STANCE_WEIGHT = 1.0


@dataclass(frozen=True)
class Stance:
    """One foot on the floor, held still by a single-view fit's second pass.

    Attributes:
        side: ``"left"`` or ``"right"``. start, stop: its first and one past its last frame.
        time: its first and last frames' times [s]. targets: (p, 2) each sole point's
            horizontal place [m] over the stance (the first fit's mean over the frames the point
            was on the floor; NaN: never on it). on: (stop - start, p) the frames each point is
            pinned in. slide: the first fit's largest horizontal distance of a pinned point from
            its place over the stance [m] (what the pin removed).
    """

    side: str
    start: int
    stop: int
    time: tuple[float, float]
    targets: np.ndarray
    on: np.ndarray
    slide: float


def _hysteresis(enter: np.ndarray, stay: np.ndarray) -> np.ndarray:
    """Frames in runs that start where ``enter`` holds and last while ``stay`` does (both ways
    in time: a run reaches back over the ``stay`` frames before its first ``enter``)."""
    out = np.zeros(len(enter), dtype=bool)
    for i in np.flatnonzero(enter):
        if out[i]:
            continue
        a = b = i
        while a > 0 and stay[a - 1]:
            a -= 1
        while b + 1 < len(stay) and stay[b + 1]:
            b += 1
        out[a : b + 1] = True
    return out


def _runs(x: np.ndarray) -> list[tuple[int, int]]:
    """The runs of True in ``x``: (start, stop) index pairs."""
    edges = np.diff(np.concatenate([[0], x.astype(int), [0]]))
    return list(zip(np.flatnonzero(edges == 1), np.flatnonzero(edges == -1), strict=True))


def sole_world(h, q: np.ndarray) -> dict[str, np.ndarray]:
    """Each foot's sole points in the world over the configurations ``q`` (n, nq):
    {side: (n, p, 3)} [m]."""
    model = h.model
    data = model.createData()
    pts = {s: h.sole_points(s) for s in SIDES}
    out = {s: np.zeros((len(q), len(pts[s]), 3)) for s in SIDES}
    for i, qi in enumerate(q):
        pin.framesForwardKinematics(model, data, qi)
        for s in SIDES:
            M = data.oMf[h.sole_id(s)]
            out[s][i] = pts[s] @ M.rotation.T + M.translation
    return out


def find_stances(h, time: np.ndarray, q: np.ndarray) -> list[Stance]:
    """The feet planted on the floor z = 0 in a fitted motion (``time`` (n,) [s], ``q``
    (n, nq)): per foot, the runs of frames where its lowest sole point is low (within
    :data:`STANCE_LOW` of the floor to start, :data:`STANCE_HIGH` to stay) and slow (its
    horizontal speed below :data:`STANCE_SLOW` to start, :data:`STANCE_FAST` to stay), at least
    :data:`STANCE_SHORTEST` long; in each, every sole point within :data:`POINT_LOW` of the
    floor is on it, its place the mean of its horizontal positions there.

    Returns:
        The stances, by foot and then by time (none: no foot planted, or fewer than 3 frames).
    """
    time = np.asarray(time, dtype=float)
    if len(time) < 3:
        return []
    world = sole_world(h, q)
    out = []
    for s in SIDES:
        p = world[s]
        k = np.argmin(p[:, :, 2], axis=1)
        low = p[np.arange(len(p)), k, 2]
        xy = p[:, :, :2]
        # each point's horizontal velocity (central differences), taken at the lowest point
        vel = np.gradient(xy, time, axis=0)
        speed = np.linalg.norm(vel[np.arange(len(p)), k], axis=1)
        planted = _hysteresis((low < STANCE_LOW) & (speed < STANCE_SLOW),
                              (low < STANCE_HIGH) & (speed < STANCE_FAST))  # fmt: skip
        for a, b in _runs(planted):
            if time[b - 1] - time[a] < STANCE_SHORTEST - 1e-9:
                continue
            on = p[a:b, :, 2] < POINT_LOW
            on[np.arange(b - a), k[a:b]] = True  # (the lowest point is on the floor)
            targets = np.full((p.shape[1], 2), np.nan)
            for j in np.flatnonzero(on.any(axis=0)):
                targets[j] = xy[a:b][on[:, j], j].mean(axis=0)
            dist = np.linalg.norm(xy[a:b] - targets[None], axis=2)
            slide = float(np.max(np.where(on, dist, 0.0)))
            out.append(Stance(s, int(a), int(b), (float(time[a]), float(time[b - 1])),
                              targets, on, slide))  # fmt: skip
    return out


class StancePins:
    """The pinned sole points' rows of a single-view fit's second pass: in each frame of a
    :class:`Stance`, each sole point on the floor held at its horizontal place."""

    def __init__(self, h, stances: list[Stance], n: int) -> None:
        self.model = h.model
        self.frames = {s: h.sole_id(s) for s in SIDES}
        points = {s: h.sole_points(s) for s in SIDES}
        # per frame: (sole frame, the point in it, its place (2,))
        self.pins: list[list] = [[] for _ in range(n)]
        for st in stances:
            for i in range(st.start, st.stop):
                for j in np.flatnonzero(st.on[i - st.start]):
                    self.pins[i].append((self.frames[st.side], points[st.side][j],
                                         st.targets[j]))  # fmt: skip

    def rows(self, data, i: int, weight: float):
        """Frame ``i``'s rows (J, r, w): each pinned point's horizontal residual [m] (its
        place minus where it is), its Jacobian, at ``weight``; ``data``'s joint Jacobians and
        frame placements up to date. None: no point pinned in the frame."""
        if not self.pins[i]:
            return None
        rows: list[np.ndarray] = []
        rhs: list[np.ndarray] = []
        for f, local, target in self.pins[i]:
            M = data.oMf[f]
            Jf = pin.getFrameJacobian(self.model, data, f, pin.LOCAL_WORLD_ALIGNED)
            world = M.act(local)
            rows.append((Jf[:3] - pin.skew(world - M.translation) @ Jf[3:])[:2])
            rhs.append(target - world[:2])
        J, r = np.vstack(rows), np.concatenate(rhs)
        return J, r, np.full(len(r), weight)
