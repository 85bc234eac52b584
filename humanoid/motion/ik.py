"""Inverse kinematics: the body's configurations that best fit measured markers or keypoints.

Each frame solves ``min_q sum_i w_i |p_i(q) - m_i|^2`` over the markers seen in that frame
(``w_i`` the marker set's weights; a marker missing in a frame, NaN, counts for nothing there)
plus the pulls below, by Levenberg-Marquardt on the configuration's Lie group: the step ``dq``
solves ``(J' W J + lambda I) dq = J' W r`` (a marker's Jacobian its joint's, moved to the
marker: all of them from one :func:`pinocchio.computeJointJacobians`), the configuration moves
by ``q (+) dq``, and joints with a range are kept inside it (a step that would leave it is
ProxQP's, with each hinge's box). Each pull on the configuration (towards standing, the held
coordinates', the smoothing's) is a residual ``q (-) target`` with its exact Jacobian
(:func:`pinocchio.dDifference`: not the identity on a ball joint), so that the steps stop at
the frame's cost's minimum. A step is taken only if that whole cost goes down; else it is
refused and ``lambda`` raised (Nielsen's rule lowers it again); a taken step is moved to the
minimum of the cost's parabola along it where that is 30 % or more off (a large residual's
Gauss-Newton steps overshoot or fall short: an unscaled body's elbows zigzagged, 50 steps a
frame). A frame stops when its next step is below ``tolerance``, or a step lowers its cost
(or the next would, by the model) by less than :data:`COST_TOLERANCE` of it: converged, either
way (the step below the bound is not taken). A small pull towards the standing posture
(``regularization``) settles what the markers cannot see (a spine of two joints seen only at
its ends, a hand without markers). Frames are solved in order, each from the frames before
moved on at their pace (their velocity and acceleration; with ``ball_ranges``, from the frame
before); the first from the standing posture moved onto the markers' centroid.

2D keypoints seen by calibrated cameras (:mod:`humanoid.motion.cameras`) are fitted the same
way, by their reprojection error: each view that sees a marker gives the two rows ``uv -
project(p_i(q))`` [px] with the projection's Jacobian, weighted by the marker's weight times
the keypoint's confidence times ``(depth / focal)^2`` (a pixel's size at the marker, so that a
view's rows weigh in metres as a 3D marker's do), shared between the views that see it; the
first frame starts on the triangulated points. The residuals are then each marker's distance
from its views' rays [m], and :attr:`IKResult.pixels` the reprojection errors [px].

What the fit hides is said (:class:`IKResult`, and a warning each):

- A joint held at its range's end (:class:`RangeLimitWarning`): the frame is solved again
  from there with every range off, and how far past the bound that fit goes is what the
  markers wanted (a joint they want less than 0.1 degree past it, as a knee standing straight
  is, is not held; a motion inside its ranges never warns).
- A coordinate no marker sees (:class:`UnconstrainedWarning`): in each frame, at its start, a
  coordinate whose column of the weighted marker Jacobian ``W^1/2 J`` has a norm below
  ``unseen`` times the largest column's (the root's translations: the square root of the
  frame's marker weight) is named and held: on it alone, the pull of ``regularization`` is
  joined by one of ``hold`` per unit of marker weight (as stiff as every marker 10 cm from
  its axis, at the default) towards the frame before (the standing posture on the first), so
  that noise on markers that barely see it cannot swing it (a hand seen by a marker 3 mm
  from its wrist, 1 mm of noise: 6.6 degrees of swing without, none with). Only single
  coordinates are checked: a combination the markers do not see (the spine's two joints'
  shared twist) is left to ``regularization``.

The residual of every marker in every frame is kept: a person is not the body, so a marker
that does not fit says where.
"""

from __future__ import annotations

import math
import warnings
from dataclasses import dataclass, field, replace
from typing import TYPE_CHECKING, NamedTuple

import numpy as np
import pinocchio as pin

from ..errors import IKError, ModelError
from ..linalg import spd_solve
from ..model import SIDES
from .inverse_dynamics import joint_labels
from .markers import MAX_WEIGHT, Marker, MarkerTrajectories

if TYPE_CHECKING:
    from .monocular import DepthReport

__all__ = [
    "IKResult",
    "LimitReport",
    "RangeLimitWarning",
    "SPARSE_SMOOTHING",
    "UnconstrainedWarning",
    "inverse_kinematics",
    "register_markers",
]

SPARSE_SMOOTHING = 1e-7  # [s^2]: 1e-3 per marker weight at 100 Hz
SINGLE_VIEW_GROUND = 1.0  # the feet's pull onto the floor from one view, per marker weight
# Points that do not show the feet's orientation (joint centres to the ankles: Human3.6M's and
# COCO's 17): a stance foot's sole is pulled level through the ankle's coordinates (a flat
# foot), per marker weight. Held where they were instead, the feet pitched as they happened to
# be and tracking fell within a second (the 3-step walk, 1 cm of noise: 5 seeds of 5, lost at
# 0.13 s); with the pull, 5 of 5 tracked to the end. Pulled onto the floor z = 0 instead (as
# from one view), the clean walk's knees came out 7.7 deg off (the swing feet's held pitch put
# their toes through it); every sole pulled level, swing feet too, 44 deg off (a swinging
# foot's level is past its ankle's range: the pull outweighed the markers)
LEVEL_SOLES = 0.1
LEVEL_HEIGHT = 0.03  # [m] ... a stance foot's: its sole no higher than this above the other's
# one view (measured on the 2-step walk at 30 Hz, 3 px, side and 45-deg views, seed 0; see
# scripts/single_camera.py): the pull towards standing, per marker weight (1e-6: joints 6.3 and
# 6.4 deg RMS off, the root 89 and 100 mm along the ray, a lateral S of the spine with the
# pelvis shifted towards the camera; 1e-4: 4.4 and 4.7 deg, 59 and 52 mm; 1e-3: the knees 8-12
# deg off), ...
SINGLE_VIEW_REGULARIZATION = 1e-4
# [s^2] ... and the root's pull along the ray towards its constant-velocity path (0: the
# root's depth jumped 59 mm RMS frame to frame; 1e-5: 16 mm, 49 and 45 mm off; 1e-4: drifts
# to 170 mm)
SINGLE_VIEW_ROOT = 1e-5
# [s^2] ... and the joints' smoothing, ten times :data:`SPARSE_SMOOTHING` (seed 0, side: 4.4 ->
# 3.6 deg, the root 49 -> 37 mm along the ray)
SINGLE_VIEW_SMOOTHING = 1e-6
AT_LIMIT = 1e-6  # [rad]: a joint this close to its range's bound is at it
ROOT_VELOCITY = ("tx", "ty", "tz", "rx", "ry", "rz")  # the root's coordinates' names' suffixes
# Levenberg-Marquardt: a refused step's lambda, first, relative to the system's mean diagonal
LM_START = 1e-3
# ... and a frame whose steps are refused until lambda is this many times the mean diagonal
# stops, not converged (its steps are then below rounding; a QP with such a system never
# returned)
LM_GIVE_UP = 1e12
ROUNDING = 1e-12  # a relative change of a frame's cost this small is rounding
# a frame stops when a step lowers its cost by less than this, relative, or the model says the
# next would (or when the step is below ``tolerance``); 1e-10 took subject01's walk 16.5 steps a
# frame, 1e-9 11.7, 1e-8 9.1, the spine's twist, which only the pull towards standing sees,
# crawling along its valley
COST_TOLERANCE = 1e-9
# a taken step is tried at the minimum of the cost's parabola along it where that is this much
# (relative) shorter or longer, ...
RESCALE = 0.3
MAX_EXTEND = 20.0  # ... and at most this many times as long
REFIT_STEPS = 2  # Gauss-Newton steps of a frame at a bound, solved again with the ranges off
PAST_LIMIT = math.radians(0.1)  # a joint at its bound is held there if the markers want this more
# [rad] a ball joint's rows nearer a bound than this enter the step's constraints (its angles
# are not linear in the step: the rows are linearised where the step starts)
BALL_MARGIN = 0.3
# [rad] a ball joint's angle this close to its bound is at it (the linearised rows leave it a
# little off the bound when the frame stops)
BALL_AT_LIMIT = 1e-4


class RangeLimitWarning(UserWarning):
    """Inverse kinematics held a joint at its range's bound where the markers wanted more."""


class UnconstrainedWarning(UserWarning):
    """Inverse kinematics met coordinates that no marker sees, and held them."""


@dataclass
class LimitReport:
    """Attributes:
    coordinate: The joint's name. limit: ``"lower"`` or ``"upper"``. bound: the limit [deg].
    frames: how many frames the joint was held there. start, end: the first and the last of
        them [s]. excess: the most the markers wanted past the bound, over those frames
        (the frame solved again with the ranges off) [deg].
    """

    coordinate: str
    limit: str
    bound: float
    frames: int
    start: float
    end: float
    excess: float

    def describe(self, total: int | None = None) -> str:
        """One line: the joint, its bound, its frames (of ``total``), what the markers wanted."""
        wanted = self.bound + (self.excess if self.limit == "upper" else -self.excess)
        of = f" of {total}" if total is not None else ""
        return (f"{self.coordinate} held at its {self.limit} limit {self.bound:.1f} deg in "
                f"{self.frames}{of} frames ({self.start:.2f}-{self.end:.2f} s); the markers "
                f"wanted up to {wanted:.1f} deg")  # fmt: skip


@dataclass
class IKResult:
    """Attributes:
    time: (n,) [s]. q: (n, nq). names: the markers used, in the order of ``residuals``.
    residuals: (n, m) distance between each model marker and the measured one [m] (NaN
        where the marker was missing). iterations: per frame. converged: per frame.
    at_limit: The joints held at a range's bound where the markers wanted past it, one
        report per joint and bound, the largest excess first.
    coordinates: A name per velocity coordinate (a one-DoF joint's own; ``<joint>_x/_y/_z``
        for a spherical joint's local axes; the root's ``<root>_tx..tz, rx..rz``).
    held: (n, nv) the coordinates no marker saw in each frame, held (module docstring).
    pixels: (n, m) a fit to 2D keypoints: each marker's RMS reprojection error over the views
        that saw it [px] (``residuals`` is then its distance from their rays [m]).
    """

    time: np.ndarray
    q: np.ndarray
    names: list[str]
    residuals: np.ndarray
    iterations: np.ndarray
    converged: np.ndarray
    marker_set: dict | None = None
    at_limit: list[LimitReport] = field(default_factory=list)
    coordinates: list[str] = field(default_factory=list)
    held: np.ndarray | None = None
    pixels: np.ndarray | None = None
    depth: DepthReport | None = None

    @property
    def unconstrained(self) -> list[str]:
        """The coordinates no marker saw in at least one frame (held there)."""
        if self.held is None:
            return []
        held = np.asarray(self.held.any(axis=0))  # per coordinate
        return [c for c, h in zip(self.coordinates, held, strict=True) if h]

    def marker_rms(self) -> dict[str, float]:
        """Each marker's RMS residual over the frames it was seen in [m]."""
        seen = np.isfinite(self.residuals).any(axis=0)
        return {n: float(np.sqrt(np.nanmean(self.residuals[:, i] ** 2)))
                for i, n in enumerate(self.names) if seen[i]}  # fmt: skip

    def marker_max(self) -> dict[str, float]:
        """Each marker's largest residual over the frames it was seen in [m]."""
        seen = np.isfinite(self.residuals).any(axis=0)
        return {n: float(np.nanmax(self.residuals[:, i]))
                for i, n in enumerate(self.names) if seen[i]}  # fmt: skip

    def frame_rms(self) -> np.ndarray:
        """Each frame's RMS residual over its seen markers, weighted equally [m]."""
        return np.sqrt(np.nanmean(self.residuals**2, axis=1))


def _limit_reports(model, time, q, wanted) -> list[LimitReport]:
    """The joints held at a bound in ``q`` where ``wanted`` (the fits with the ranges off, NaN
    in frames that needed none) goes past it."""
    joints, labels = model.joints, model.names
    names = {joints[j].idx_q: labels[j] for j in range(1, model.njoints)}
    out = []
    for _, iq, lo, hi in _ranges(model):
        for limit, bound, sign in (("lower", lo, -1.0), ("upper", hi, 1.0)):
            excess = sign * (wanted[:, iq] - bound)
            held = (np.abs(q[:, iq] - bound) < AT_LIMIT) & (excess > PAST_LIMIT)
            if held.any():
                t = time[held]
                out.append(LimitReport(names[iq], limit, math.degrees(bound), int(held.sum()),
                                       float(t[0]), float(t[-1]),
                                       math.degrees(float(excess[held].max()))))  # fmt: skip
    return sorted(out, key=lambda r: -r.excess)


def _ranges(model):
    """(index in v, index in q, lower, upper) of the one-coordinate joints with finite ranges."""
    out = []
    lower, upper = model.lowerPositionLimit, model.upperPositionLimit
    for joint in list(model.joints)[1:]:
        if joint.nq == 1 and joint.nv == 1:
            lo, hi = lower[joint.idx_q], upper[joint.idx_q]
            if math.isfinite(lo) and math.isfinite(hi) and hi > lo:
                out.append((joint.idx_v, joint.idx_q, float(lo), float(hi)))
    return out


class _Box(NamedTuple):
    """The ranged hinges of :func:`_ranges` as arrays: their indices in v and q, their bounds."""

    iv: np.ndarray
    iq: np.ndarray
    lo: np.ndarray
    hi: np.ndarray

    @classmethod
    def of(cls, ranges) -> _Box:
        cols = list(zip(*ranges, strict=True)) or [(), (), (), ()]
        return cls(np.array(cols[0], dtype=int), np.array(cols[1], dtype=int),
                   np.array(cols[2], dtype=float), np.array(cols[3], dtype=float))  # fmt: skip


def _bounded_step(A, b, q, box: _Box, balls=None) -> np.ndarray:
    """The step minimising 1/2 dq'A dq - b'dq with every ranged joint kept in its range: the
    unconstrained one if it stays inside, else ProxQP's solve with each hinge's box and each
    ball joint's angle rows (``balls``: a :class:`~humanoid.constraints.limits.JointRanges`,
    its rows within :data:`BALL_MARGIN` of a bound, linearised: r + J dq >= 0: a ball joint
    outside its range is brought back, :meth:`_Fit.fit_frame` takes that step whatever the
    cost)."""
    dq = spd_solve(A, b)  # (LAPACK's Cholesky: a third of numpy's solve's time here)
    if not len(box.iv) and balls is None:
        return dq
    x = q[box.iq]
    lo = box.lo - x
    hi = box.hi - x
    step = dq[box.iv]
    inside = bool(((step >= lo - 1e-12) & (step <= hi + 1e-12)).all())
    if balls is None:
        if inside:
            return dq
        r_b, J_b = np.zeros(0), np.zeros((0, len(b)))
    else:
        r_b, J_b = _ball_rows(balls, q, len(b), BALL_MARGIN)
        if inside and bool((r_b + J_b @ dq >= -1e-12).all()):
            return dq
    import proxsuite

    C = np.zeros((len(box.iv), len(b)))
    C[np.arange(len(box.iv)), box.iv] = 1.0
    C = np.vstack([C, J_b])
    low = np.concatenate([np.minimum(lo, 0.0), -r_b])
    up = np.concatenate([np.maximum(hi, 0.0), np.full(len(r_b), 1e20)])
    res = proxsuite.proxqp.dense.solve(A, -b, None, None, C, low, up, eps_abs=1e-10)
    return np.asarray(res.x)


def _room(q, dq, box: _Box, balls) -> float:
    """How many times ``dq`` the ranged hinges allow from ``q`` (1 with ball ranges: their rows
    are linearised)."""
    if balls is not None:
        return 1.0
    step = dq[box.iv]
    x = q[box.iq]
    with np.errstate(divide="ignore", invalid="ignore"):
        room = np.where(step > 0.0, (box.hi - x) / step,
                        np.where(step < 0.0, (box.lo - x) / step, np.inf))  # fmt: skip
    return float(room.min()) if len(room) else math.inf


def _ball_rows(balls, q, nv: int, margin: float) -> tuple[np.ndarray, np.ndarray]:
    """The ball joints' range rows (r, J) within ``margin`` [rad] of a bound (none without
    ``balls``): :meth:`~humanoid.constraints.limits.JointRanges.rows` lists the hinges' first."""
    if balls is None:
        return np.zeros(0), np.zeros((0, nv))
    r, J = balls.rows(q, margin=margin, certified=False)
    k = int((balls.hinge_rows(q)[0] < margin).sum())
    return r[k:], J[k:]


def _ball_reports(balls, time, q, wanted) -> list[LimitReport]:
    """The ball joints' angles held at a bound in ``q`` where ``wanted`` (NaN in frames that
    needed no refit) goes past it, named by the hinges they replace."""
    out: list[LimitReport] = []
    if balls is None or not balls.balls:
        return out
    rows = np.flatnonzero(np.all(np.isfinite(wanted), axis=1))
    if not len(rows):
        return out
    got = np.array([balls.angles(q[i], remember=False) for i in rows])
    want = np.array([balls.angles(wanted[i], remember=False) for i in rows])
    for b, (ball, *_, lower, upper) in enumerate(balls.balls):
        for a, hinge in enumerate(ball.hinges):
            for limit, bound, sign in (("lower", lower[a], -1.0), ("upper", upper[a], 1.0)):
                excess = sign * (want[:, b, a] - bound)
                held = (np.abs(got[:, b, a] - bound) < BALL_AT_LIMIT) & (excess > PAST_LIMIT)
                if held.any():
                    t = time[rows[held]]
                    out.append(LimitReport(hinge, limit, math.degrees(bound), int(held.sum()),
                                           float(t[0]), float(t[-1]),
                                           math.degrees(float(excess[held].max()))))  # fmt: skip
    return out


def inverse_kinematics(h, markers: MarkerTrajectories, marker_set: dict[str, Marker], *,
                       register: bool = False, static: MarkerTrajectories | None = None,
                       iterations: int = 50, tolerance: float = 1e-6, damping: float = 1e-6,
                       regularization: float | None = None, smoothing: float | None = None,
                       unseen: float = 1e-3, hold: float = 1e-2, q0: np.ndarray | None = None,
                       cameras=None, ball_ranges: bool = False, ground: float | None = None,
                       root_smoothing: float | None = None, stances: bool | None = None,
                       progress=None) -> IKResult:  # fmt: skip
    """Fit the body to measured markers, or to 2D keypoints seen by calibrated cameras (see
    the module docstring).

    Args:
        h: The body. markers: Measured trajectories (our axes, metres). marker_set: Where the
            markers are on the body; only the names both have are used.
        register: If the set has technical markers (:class:`~humanoid.motion.markers.Marker`
            ``anatomical=False``), first fit the anatomical ones alone, put each technical
            marker at its mean place on its frame over that fit (OpenSim's scaling moves
            model markers onto a static trial's the same way), then fit all.
        static: Register on this trial (a person standing still, as labs record one before
            walking) instead of on the motion itself.
        iterations: Steps per frame at most (Levenberg-Marquardt's). tolerance: a frame stops
            when its next step is smaller than this [rad or m] (or its cost no longer goes
            down: module docstring). damping: Levenberg's lambda, at least.
        regularization: The pull towards the standing posture, per unit of marker weight.
        smoothing: The pull of the joints (not the root) towards the frame before, on their
            velocity (the weight is this over the frame interval squared, per unit of marker
            weight; default: none with 40 markers or more; :data:`SPARSE_SMOOTHING` with
            fewer, as keypoints are, which leave a limb's twist unseen and noise free to turn
            it: with 1 cm of noise on BODY_25's points of the walk at 100 Hz the fit was 8.8
            degrees RMS off without it, 4.0 with it, 2.6 with the unseen hand and neck held).
        unseen: A coordinate whose weighted marker-Jacobian column is below this times the
            largest column's is unseen in that frame (0: none is). hold: The pull on an unseen
            coordinate towards the frame before, per unit of marker weight [m^2 per rad^2].
        q0: The first frame's starting configuration (default: see the module docstring).
        cameras: ``markers`` are 2D keypoints (:class:`~humanoid.motion.cameras.
            CameraKeypoints`) and these their cameras (:func:`~humanoid.motion.cameras.
            read_calibration`, in the keypoints' order): the fit minimises the reprojection
            error, each view's pixels weighed by their size at the marker (module docstring);
            the first frame starts from the triangulated points.
        ball_ranges: Keep the ball joints in their ranges too (each angle of the hinge
            triplet a ball replaces), reported as the hinges' are; default: hinges only. On
            OpenSim's subject01 walk the trunk's markers (placed on a static trial with the
            arms raised, the acromia 8 cm higher) want the thoracic joint flexed up to 86 deg:
            held at its 45, the pelvis tilts instead and the thighs' markers go from 9-14 to
            17-27 mm RMS, the root residual from 5.0 to 7.1 % BW (``tests/test_real_trial.py``).
        ground: One view: the feet's pull onto the floor z = 0, per marker weight (default
            :data:`SINGLE_VIEW_GROUND` from one view, else 0; :data:`LEVEL_SOLES`: feet unseen).
        root_smoothing: One view: the root's pull along the ray towards its constant-velocity
            path [s^2] (default :data:`SINGLE_VIEW_ROOT` from one view, 0 otherwise).
        stances: One view with the floor: fit twice, the second time backwards in time from
            the first fit's last frame, with each foot that the first fit has planted on the
            floor held still over its stance (its sole points on the floor pinned to their mean
            horizontal places: :func:`~humanoid.motion.monocular.find_stances`), so that the
            planted foot, not the pixels' noise, fixes the depth along the ray, and the first
            frames, whose depth the forward fit has no past to hold, are reached with one
            (module :mod:`~humanoid.motion.monocular`); said in the
            :class:`~humanoid.motion.monocular.DepthReport`. Default: on from one view with
            ``ground``, off otherwise (several views or markers see the depth).
        progress: Called with the frame index after each frame (the first pass's only).

    Warns:
        RangeLimitWarning: joints held at their range's bounds (:attr:`IKResult.at_limit`).
        UnconstrainedWarning: coordinates no marker sees (:attr:`IKResult.unconstrained`).

    Raises:
        IKError: no marker in common, a marker on a frame the body does not have, a frame
            with fewer than 3 markers seen in total for the first frame.
    """
    settings = _settings(h, markers, marker_set, cameras, register or static is not None,
                         iterations=iterations, tolerance=tolerance, damping=damping,
                         regularization=regularization, smoothing=smoothing, unseen=unseen,
                         hold=hold, ground=ground, root_smoothing=root_smoothing)  # fmt: skip
    if register:
        marker_set, q0 = _registered(h, markers, marker_set, settings, static, q0, progress)
    result = _solve(h, markers, marker_set, settings, q0, progress, cameras, ball_ranges)
    if len(cameras or ()) == 1 and (bool(settings.ground) if stances is None else stances):
        result = _planted(h, markers, marker_set, settings, result, cameras, ball_ranges)
    result.marker_set = marker_set
    _warn(result, cameras, settings.ground)
    return result


def _ankle_columns(h) -> np.ndarray:
    """The velocity coordinates of the ankles (a bool per coordinate): each sole's joint and
    its parents that share its centre (the flexion and inversion hinges)."""
    model = h.model
    data = model.createData()
    pin.forwardKinematics(model, data, h.standing_configuration())
    out = np.zeros(model.nv, dtype=bool)
    for s in SIDES:
        j = model.frames[h.sole_id(s)].parentJoint
        centre = data.oMi[j].translation.copy()
        while j > 1 and np.linalg.norm(data.oMi[j].translation - centre) < 1e-6:
            jm = model.joints[j]
            out[jm.idx_v : jm.idx_v + jm.nv] = True
            j = model.parents[j]
    return out


def _level_rows(model, data, soles: list[int], ankles: np.ndarray, weight: float,
               keep: np.ndarray):  # fmt: skip
    """The stance soles' tilt from level (J, r, w): for each sole no more than
    :data:`LEVEL_HEIGHT` above the lowest, the rotation about the world's x and y that brings
    its normal to the vertical (its axis and angle), and the sole frame's angular Jacobian rows
    on the ``ankles`` coordinates that the frame holds (``keep`` > 0: no marker sees them), so
    that the pull levels the foot, not the leg the markers place; ``data`` at the
    configuration."""
    held = (keep > 0) & ankles
    J, r = [], []
    low = min(float(data.oMf[f].translation[2]) for f in soles)
    for f in soles:
        if float(data.oMf[f].translation[2]) > low + LEVEL_HEIGHT:
            continue  # (a swing foot: pitched as it swings)
        n = data.oMf[f].rotation[:, 2]
        axis = np.array([n[1], -n[0], 0.0])  # n x e_z
        sine = float(np.linalg.norm(axis))
        angle = math.atan2(sine, float(n[2]))
        r.append(axis[:2] * (angle / sine) if sine > 1e-12 else np.zeros(2))
        J.append(pin.getFrameJacobian(model, data, f, pin.LOCAL_WORLD_ALIGNED)[3:5] * held)
    return np.vstack(J), np.concatenate(r), np.full(len(r) * 2, weight)


def _feet_unseen(h, markers: MarkerTrajectories, marker_set) -> bool:
    """Whether no marker shows either foot's orientation: none of those weighted is on a
    foot past its ankle's centre (a body without the toolkit's soles: False)."""
    model = h.model
    try:
        soles = [model.frames[h.sole_id(s)].parentJoint for s in SIDES]
    except ModelError:  # (a body whose sole frames are not there: nothing to say)
        return False
    names = [n for n in markers.names if n in marker_set and marker_set[n].weight > 0]
    joints = {model.frames[model.getFrameId(marker_set[n].frame)].parentJoint for n in names}
    return bool(names) and not any(j in model.subtrees[f] for f in soles for j in joints)


def _settings(h, markers, marker_set, cameras, registering: bool, **given) -> _Settings:
    """The fit's settings, the defaults of one view or of few markers filled in, checked."""
    from .cameras import CameraKeypoints

    if isinstance(markers, CameraKeypoints) != (cameras is not None):
        raise IKError("2D keypoints (CameraKeypoints) need their cameras, and cameras "
                      "need 2D keypoints")  # fmt: skip
    if cameras is not None and registering:
        raise IKError("registering technical markers needs 3D markers, not 2D keypoints")
    single = cameras is not None and len(cameras) == 1  # (the defaults of one view)
    if given.get("level") is None:
        given["level"] = LEVEL_SOLES if _feet_unseen(h, markers, marker_set) else 0.0
    if given["ground"] is None:
        given["ground"] = SINGLE_VIEW_GROUND if single else 0.0
    if given["root_smoothing"] is None:
        given["root_smoothing"] = SINGLE_VIEW_ROOT if single else 0.0
    if given["regularization"] is None:
        given["regularization"] = SINGLE_VIEW_REGULARIZATION if single else 1e-6
    _check_settings(**given)
    names = [n for n in markers.names if n in marker_set]
    heavy = [n for n in names if not 0.0 <= marker_set[n].weight <= MAX_WEIGHT]
    if heavy:
        raise IKError(f"marker {heavy[0]!r}: weight {marker_set[heavy[0]].weight} must be "
                      f"in [0, {MAX_WEIGHT:g}]")  # fmt: skip
    if given["smoothing"] is None:
        smoothing = 0.0 if len(names) >= 40 else SPARSE_SMOOTHING
        given["smoothing"] = SINGLE_VIEW_SMOOTHING if single else smoothing
    return _Settings(**given)


def _registered(h, markers, marker_set, settings: _Settings, static, q0, progress):
    """The marker set with its technical markers registered (:func:`inverse_kinematics`'
    ``register``), and the first frame's start (the registering fit's, on the motion)."""
    names = [n for n in markers.names if n in marker_set]
    technical = [n for n in names if not marker_set[n].anatomical]
    if not technical or len(technical) == len(names):
        return marker_set, q0
    first = {n: (replace(m, weight=0.0, anatomical=False) if n in technical else m)
             for n, m in marker_set.items()}  # fmt: skip
    source = static if static is not None else markers
    technical = [n for n in technical if n in source.names]
    markers_only = replace(settings, ground=0.0, root_smoothing=0.0)  # (3D markers: no view)
    fit = _solve(h, source, first, markers_only, q0, progress if static is None else None)
    marker_set = dict(marker_set) | register_markers(h, source, fit.q, marker_set, technical,
                                                     fit.held)  # fmt: skip
    return marker_set, (fit.q[0] if static is None else q0)


def _planted(h, markers, marker_set, settings: _Settings, result: IKResult, cameras,
             ball_ranges: bool) -> IKResult:  # fmt: skip
    """One view: the fit solved again, backwards, the feet ``result`` planted held still."""
    from .monocular import StancePins, find_stances

    found = find_stances(h, result.time, result.q)
    pins = StancePins(h, found, len(result.time)) if found else None
    result = _solve(h, markers, marker_set, settings, result.q[-1], None, cameras, ball_ranges,
                    pins, backward=True)  # fmt: skip
    assert result.depth is not None  # one view: the solve reported the depth
    result.depth = replace(result.depth, stances=tuple(found))
    return result


def _warn(result: IKResult, cameras, ground: float) -> None:
    """The warnings of what the fit hid (module docstring; one view's depth:
    :func:`~humanoid.motion.monocular.check_single_view`), at :func:`inverse_kinematics`'
    caller."""
    if result.depth is not None:
        from .monocular import check_single_view

        check_single_view(result.depth, cameras[0], ground, stacklevel=4)
    if result.at_limit:
        warnings.warn("inverse kinematics: " + "; ".join(
            r.describe(len(result.time)) for r in result.at_limit) + " (a subject whose "
            "range is wider: give the body theirs, --range JOINT=LOWER,UPPER or "
            "BodyParameters(ranges=...))", RangeLimitWarning, stacklevel=3)  # fmt: skip
    if result.unconstrained:
        assert result.held is not None  # unconstrained coordinates are held ones
        counts = result.held.sum(axis=0)
        named = [f"{c} ({counts[k]} of {len(result.time)} frames)"
                 for k, c in enumerate(result.coordinates) if counts[k]]  # fmt: skip
        warnings.warn("inverse kinematics: no marker sees " + ", ".join(named)
                      + "; held at the frame before (the standing posture at first)",
                      UnconstrainedWarning, stacklevel=3)  # fmt: skip


# the largest value of an IK setting (a weight or pull per unit of marker weight, a tolerance):
# the defaults are 1e-6 to 1e2; nan or inf made the fit never return
MAX_SETTING = 1e12


def _check_settings(**settings) -> None:
    """Raise HumanoidError naming the setting if one (None: its default) is not a number in
    [0, :data:`MAX_SETTING`]."""
    for key, value in settings.items():
        if value is None:
            continue
        if (
            isinstance(value, bool)
            or not isinstance(value, int | float | np.number)
            or not (0.0 <= float(value) <= MAX_SETTING)
        ):
            raise IKError(f"inverse kinematics: {key} must be a number in "
                          f"[0, {MAX_SETTING:g}], got {value!r}")  # fmt: skip
    if settings.get("iterations") is not None and int(settings["iterations"]) < 1:
        raise IKError(f"inverse kinematics: iterations must be at least 1, got "
                      f"{settings['iterations']!r}")  # fmt: skip


def register_markers(h, markers: MarkerTrajectories, q: np.ndarray, marker_set: dict,
                     names, held: np.ndarray | None = None) -> dict[str, Marker]:  # fmt: skip
    """The markers ``names`` moved to their mean place on their frames over the fitted
    configurations ``q`` (one per frame of ``markers``; frames where a marker is missing do not
    count, nor, given the fit's ``held`` (n, nv) coordinates, frames where the fit held one
    that moves the marker's frame: its segment was not seen there)."""
    model = h.model
    data = model.createData()
    sums = {n: np.zeros(3) for n in names}
    counts = dict.fromkeys(names, 0)
    cols = {n: markers.names.index(n) for n in names}
    moves = {}
    for n in names:  # the velocity coordinates that move the marker's frame
        joints = model.supports[model.frames[model.getFrameId(marker_set[n].frame)].parentJoint]
        moves[n] = np.concatenate([np.arange(model.joints[j].idx_v,
                                             model.joints[j].idx_v + model.joints[j].nv)
                                   for j in joints if j > 0] or [np.zeros(0, int)])  # fmt: skip
    for i, qi in enumerate(q):
        pin.framesForwardKinematics(model, data, qi)
        for n in names:
            p = markers.positions[i, cols[n]]
            unseen = held is not None and bool(held[i, moves[n]].any())
            if np.all(np.isfinite(p)) and not unseen:
                sums[n] += data.oMf[model.getFrameId(marker_set[n].frame)].actInv(p)
                counts[n] += 1
    out = {}
    for n in names:
        m = marker_set[n]
        offset = sums[n] / counts[n] if counts[n] else np.array(m.offset)
        out[n] = replace(m, offset=tuple(float(x) for x in offset))
    return out


def _extrapolated(model, t: float, history) -> np.ndarray:
    """The configuration at time ``t`` from the last frames solved (``history``: 2 or 3
    (time, q), the last last) at their pace: their velocity and, from 3, their acceleration
    (a frame's start: on the bench's walk at 100 Hz a frame took 4.0 steps from the frame
    before, 3.0 from its velocity's start, 2.3 with the acceleration's)."""
    (t1, q1), (t2, q2) = history[-2:]
    h, tau1 = t - t2, t2 - t1
    v1 = pin.difference(model, q1, q2) / tau1
    step = v1 * h
    if len(history) > 2:
        t0, q0 = history[-3]
        tau0 = t1 - t0
        accel = (v1 - pin.difference(model, q0, q1) / tau0) / (0.5 * (tau0 + tau1))
        step += 0.5 * accel * h * (tau1 + h)
    return pin.integrate(model, q2, step)


def _centroid_shift(points, seen, P, i: int, time: float) -> np.ndarray:
    """The mean of ``points - P`` over the seen, finite points (at least 3) of frame ``i``."""
    ok = np.all(np.isfinite(points), axis=1) & seen
    if ok.sum() < 3:
        raise IKError(f"frame {i} ({time:.3f} s): fewer than 3 markers seen")
    return (points[ok] - P[ok]).mean(axis=0)


class _Points:
    """Measured 3D markers as the fit's observations: each seen marker gives three rows,
    ``measured - model`` [m], weighted by its set's weight."""

    def __init__(self, markers: MarkerTrajectories, names, weights) -> None:
        cols = [markers.names.index(n) for n in names]
        self.meas = markers.positions[:, cols]
        self.weights = weights

    def seen(self, i: int) -> np.ndarray:
        """The markers seen in frame ``i``."""
        return np.all(np.isfinite(self.meas[i]), axis=1) & (self.weights > 0)

    def place(self, i: int, seen, P, time: float) -> np.ndarray:
        """The translation [m] that moves the model's markers ``P`` onto frame ``i``'s (their
        centroids'), to start the first frame from."""
        return _centroid_shift(self.meas[i], seen, P, i, time)

    def rows(self, i, seen, P, Jp):
        """The fit's rows at the model's markers ``P`` (m, 3) with their Jacobians ``Jp``
        (m, 3, nv): (J, r, w), the rows' Jacobians, residuals and weights."""
        w = np.repeat(np.where(seen, self.weights, 0.0), 3)
        r = np.where(seen[:, None], self.meas[i] - P, 0.0).reshape(-1)
        return Jp.reshape(-1, Jp.shape[-1]), r, w

    def error(self, i, seen, P) -> np.ndarray:
        """Each seen marker's distance from the model's [m] (NaN: unseen)."""
        return np.where(seen, np.linalg.norm(P - self.meas[i], axis=1), np.nan)


class _Views:
    """2D keypoints in calibrated cameras as the fit's observations (the reprojection error):
    each camera that sees a marker gives two rows, ``measured - projected`` [px], weighted by
    the set's weight times the keypoint's confidence times ``(depth / focal)^2`` (a pixel's
    size at the marker [m], so that a view's rows weigh as a 3D marker's would), shared
    between the views that see it (3 rows' worth in all)."""

    def __init__(self, keypoints, cameras, names, weights) -> None:
        from .cameras import match_cameras, triangulate

        self.cameras = match_cameras(keypoints, cameras)
        cols = [keypoints.names.index(n) for n in names]
        self.uv = keypoints.uv[:, :, cols]
        self.conf = keypoints.confidence[:, :, cols]
        self.weights = weights
        self.single = len(self.cameras) == 1
        if not self.single:
            self.points = triangulate(keypoints, cameras).positions[:, cols]
        self.pixels: np.ndarray | None = None  # (n, m) the last fit's reprojection errors [px]

    def seen(self, i: int) -> np.ndarray:
        return (self.conf[:, i] > 0).any(axis=0) & (self.weights > 0)

    def place(self, i: int, seen, P, time: float) -> np.ndarray:
        """As :meth:`_Points.place`, on the triangulated points; from one view, the
        translation that best reprojects ``P`` (:func:`~humanoid.motion.monocular.
        place_on_rays`)."""
        if not self.single:
            return _centroid_shift(self.points[i], seen, P, i, time)
        from .monocular import place_on_rays

        ok = seen & (self.conf[0, i] > 0)
        if ok.sum() < 3:
            raise IKError(f"frame {i} ({time:.3f} s): fewer than 3 markers seen")
        return place_on_rays(self.cameras[0], self.uv[0, i, ok], P[ok])

    def ray(self, point) -> np.ndarray:
        """The unit direction from the (first) camera to ``point`` [m]."""
        d = np.asarray(point, dtype=float) - self.cameras[0].centre
        return d / np.linalg.norm(d)

    def root_depth(self, q, A, J, w) -> np.ndarray:
        """From one view: the standard deviations of the root's position along the camera's
        ray through it and across it (the largest) [m] for one pixel of noise on every row,
        from the Gauss-Newton system ``A`` with the rows' Jacobian ``J`` [px] and weights
        ``w``; and its distance from the camera [m]."""
        Ai = np.linalg.inv(A)
        JW = J.T * w
        cov = (Ai @ JW @ JW.T @ Ai)[:3, :3]  # the root's translation, in its own frame
        R = pin.Quaternion(q[6], q[3], q[4], q[5]).toRotationMatrix()
        cov = R @ cov @ R.T
        cam = self.cameras[0]
        ray = q[:3] - cam.centre
        distance = float(np.linalg.norm(ray))
        u = ray / distance
        along = float(u @ cov @ u)
        P = np.eye(3) - np.outer(u, u)
        across = float(np.linalg.eigvalsh(P @ cov @ P).max())
        return np.array([math.sqrt(max(along, 0.0)), math.sqrt(max(across, 0.0)), distance])

    def rows(self, i, seen, P, Jp):
        share = 1.5 / np.maximum((self.conf[:, i] > 0).sum(axis=0), 1)
        Js, rs, ws = [], [], []
        for c, cam in enumerate(self.cameras):
            ok = seen & (self.conf[c, i] > 0) & (cam.depth(P) > 1e-3)
            uv, D = cam.project(P, jacobian=True)
            w = np.where(ok, self.weights * self.conf[c, i] * share, 0.0)
            w = w * (np.where(ok, cam.depth(P), 0.0) / cam.focal) ** 2
            Js.append(np.einsum("mij,mjk->mik", np.nan_to_num(D), Jp).reshape(-1, Jp.shape[-1]))
            rs.append(np.where(ok[:, None], self.uv[c, i] - uv, 0.0).reshape(-1))
            ws.append(np.repeat(w, 2))
        return np.vstack(Js), np.concatenate(rs), np.concatenate(ws)

    def error(self, i, seen, P) -> np.ndarray:
        """Each seen marker's RMS distance from the rays of the views that see it [m] (the
        reprojection error at its depth); the pixels' kept in :attr:`pixels`."""
        ray2, px2, count = np.zeros(len(P)), np.zeros(len(P)), np.zeros(len(P))
        for c, cam in enumerate(self.cameras):
            ok = seen & (self.conf[c, i] > 0)
            d = np.linalg.norm(np.nan_to_num(cam.project(P) - self.uv[c, i]), axis=1)
            px2 += np.where(ok, d**2, 0.0)
            ray2 += np.where(ok, (d * cam.depth(P) / cam.focal) ** 2, 0.0)
            count += ok
        if self.pixels is None:
            self.pixels = np.full((len(self.uv[0]), len(P)), np.nan)
        with np.errstate(invalid="ignore", divide="ignore"):
            self.pixels[i] = np.where(count > 0, np.sqrt(px2 / count), np.nan)
            return np.where(count > 0, np.sqrt(ray2 / count), np.nan)


@dataclass(frozen=True)
class _Settings:
    """The fit's settings (:func:`inverse_kinematics`' arguments, their defaults resolved)."""

    iterations: int
    tolerance: float
    damping: float
    regularization: float
    smoothing: float
    unseen: float
    hold: float
    ground: float = 0.0
    root_smoothing: float = 0.0
    level: float = 0.0  # the soles' pull level (:data:`LEVEL_SOLES`), per marker weight


class _MarkerKinematics:
    """The model's markers (m, 3) at a configuration and their Jacobians (m, 3, nv), all at
    once: a marker's velocity is its joint's spatial velocity (the world-frame Jacobian of one
    :func:`pinocchio.computeJointJacobians`, on the columns that move the joint) at the marker,
    ``v + w x p``."""

    def __init__(self, model, data, frames, offsets, frames_needed: bool) -> None:
        self.model, self.data, self.m = model, data, len(frames)
        self.frames_needed = frames_needed  # (the floor's and the pins' rows read data.oMf)
        m = self.m
        # each marker on its frame's joint: its point in the joint's frame (homogeneous), and
        # the velocity coordinates that move it (the columns of the joint's support), per row
        model_frames, model_joints = model.frames, model.joints
        carriers = [model_frames[f].parentJoint for f in frames]
        unique, self.on_joint = np.unique(carriers, return_inverse=True)
        self.carrying = [int(j) for j in unique]
        self.in_joint = np.ones((m, 4, 1))
        for k, (f, o) in enumerate(zip(frames, offsets, strict=True)):
            self.in_joint[k, :3, 0] = model_frames[f].placement.act(o)
        supports = {j: [(model_joints[a].idx_v, model_joints[a].nv) for a in model.supports[j]
                        if a > 0] for j in self.carrying}  # fmt: skip
        moves = np.zeros((m, 3, model.nv))
        for k, j in enumerate(carriers):
            for iv, nv in supports[j]:
                moves[k, :, iv : iv + nv] = 1
        self.moves = moves.reshape(3 * m, model.nv)
        self.lever = np.zeros((m, 3, 6))  # a marker's row of [I, -skew(p)]: its velocity
        self.lever[:, [0, 1, 2], [0, 1, 2]] = 1.0  # from (v, w)
        self.cached: list = [None, None, None]  # the last configuration's markers, Jacobians

    def __call__(self, q):
        """The model's markers at ``q`` and their Jacobians (``data`` is then at ``q``)."""
        cached, model, data, m, lever = self.cached, self.model, self.data, self.m, self.lever
        if cached[0] is not None and np.array_equal(q, cached[0]):
            return cached[1], cached[2]  # (no floor or pins: nothing else reads data)
        pin.computeJointJacobians(model, data, q)
        if self.frames_needed:
            pin.updateFramePlacements(model, data)
        oMi = data.oMi.tolist()  # (a list's items are read in half the time)
        H = np.array([oMi[j].np[:3] for j in self.carrying])[self.on_joint]
        P = (H @ self.in_joint)[:, :, 0]
        x, y, z = P[:, 0], P[:, 1], P[:, 2]
        lever[:, 0, 4], lever[:, 0, 5] = z, -y
        lever[:, 1, 3], lever[:, 1, 5] = -z, x
        lever[:, 2, 3], lever[:, 2, 4] = y, -x
        Jp = (lever.reshape(3 * m, 6) @ data.J) * self.moves  # data.J: at the world's origin
        Jp = Jp.reshape(m, 3, model.nv)
        if not self.frames_needed:
            cached[:] = [q.copy(), P, Jp]
        return P, Jp


class _Frame(NamedTuple):
    """A frame's terms of the fit (:meth:`_Fit.terms`)."""

    i: int
    seen: np.ndarray
    reg: float  # the pull towards standing
    keep: np.ndarray | None  # the held coordinates' pulls (diagonal), or none held
    target: np.ndarray  # where the held coordinates are pulled
    smooth: float  # the joints' pull towards the frame before
    previous: np.ndarray | None  # the frame before
    total: float  # the frame's seen marker weight (at least 1)
    root_pull: tuple | None  # one view: (weight, predicted) of the root's pull


def _names_on(h, markers, marker_set) -> list[str]:
    """The markers both ``markers`` and ``marker_set`` have, each on a frame of the body."""
    model = h.model
    names = [n for n in markers.names if n in marker_set]
    if not names:
        raise IKError(
            f"no marker of {markers.source or 'the trajectories'} is in the marker set "
            f"(the file's: {', '.join(markers.names[:10])}; the set's: "
            f"{', '.join(list(marker_set)[:10])})"
        )
    for n in names:
        if not model.existFrame(marker_set[n].frame):
            raise IKError(f"marker {n!r} is on frame {marker_set[n].frame!r}, which "
                          f"{h.source} does not have")  # fmt: skip
    return names


def _inward(balls, q, q_new) -> bool:
    """Whether the step from ``q`` to ``q_new`` brings the ball joints (``balls``; None: none)
    that are outside their ranges back in (their linearised rows leave them up to about 1e-5
    rad past, and each step must bring them in): taken whatever the cost. Else a frame can
    refuse every step: subject01's walk with ball ranges stopped in its 20th frame, lambda at
    1e29 and a QP that never returned (:data:`LM_GIVE_UP` now ends such a frame, not
    converged: 3 of its 151 frames without this, none with it)."""
    if balls is None:
        return False
    out = float(balls.excess(q).sum())
    return out > 0.0 and float(balls.excess(q_new).sum()) < out


class _Fit:
    """One pass of the fit over a trial: its observations, the terms of its cost, and the
    Levenberg-Marquardt solve of one frame (module docstring). ``previous``, ``before`` and
    ``last``: the frame solved before, the one before that, and the former's index."""

    def __init__(self, h, markers, marker_set, settings: _Settings, cameras, ball_ranges: bool,
                 pins) -> None:  # fmt: skip
        model = self.model = h.model
        self.data = model.createData()
        self.markers, self.settings, self.pins = markers, settings, pins
        self.names = names = _names_on(h, markers, marker_set)
        self.frames = [model.getFrameId(marker_set[n].frame) for n in names]
        self.offsets = np.array([marker_set[n].offset for n in names])
        self.weights = weights = np.array([marker_set[n].weight for n in names])
        self.obs: _Points | _Views
        if cameras is None:
            self.obs = _Points(markers, names, weights)
        else:
            self.obs = _Views(markers, cameras, names, weights)
        self.single = getattr(self.obs, "single", False)
        self.soles = None
        if settings.ground:
            from .monocular import SolePoints

            self.soles = SolePoints(h)
        self.level = ([h.sole_id(s) for s in SIDES], _ankle_columns(h)) if settings.level else None
        self.box = _Box.of(_ranges(model))
        self.balls = None
        if ball_ranges and h.fusion is not None and h.fusion.balls:
            from ..constraints.limits import JointRanges

            self.balls = JointRanges(h)
        self.standing = h.standing_configuration()
        self.eye = np.eye(model.nv)
        self.joints = np.diag([0.0] * 6 + [1.0] * (model.nv - 6))
        floor_or_pins = self.soles is not None or pins is not None or self.level is not None
        self.model_markers = _MarkerKinematics(model, self.data, self.frames, self.offsets,
                                               floor_or_pins)  # fmt: skip
        self.previous: np.ndarray | None = None
        self.before: np.ndarray | None = None
        self.last = 0

    def system(self, q, frame: _Frame, rows=None):
        """The Gauss-Newton step's ``A dq = b`` at ``q`` in ``frame`` and the frame's cost
        there (``rows``: the observations' Jacobian, residuals and weights at ``q``, if known:
        ``data`` is then at ``q`` already). The cost is the weighted sum of squares whose
        Gauss-Newton model ``A``, ``b`` are (``damping`` aside, Levenberg's lambda, not a cost):
        the observations', the pull towards standing, the held coordinates', the smoothing's,
        one view's root pull, floor rows and pinned feet."""
        model, standing, damping = self.model, self.standing, self.settings.damping
        i, seen, reg, keep, target, smooth, previous, total, root_pull = frame
        J, r, w = self.obs.rows(i, seen, *self.model_markers(q)) if rows is None else rows
        # the pulls on the configuration: residuals q (-) target with their exact Jacobians
        # (a ball joint's is not the identity: with it, the steps' fixed point is the cost's
        # minimum)
        e = pin.difference(model, q, standing)
        De = pin.dDifference(model, q, standing, pin.ARG0)
        A = J.T @ (w[:, None] * J) + reg * (De.T @ De) + damping * self.eye
        b = J.T @ (w * r) - reg * (De.T @ e)
        c = float(r @ (w * r)) + reg * float(e @ e)
        if keep is not None:
            d = pin.difference(model, q, target)
            Dd = pin.dDifference(model, q, target, pin.ARG0)
            KD = keep[:, None] * Dd
            A += Dd.T @ KD
            b -= KD.T @ d
            c += float(d @ (keep * d))
        if smooth:  # the joints (not the root) held near the frame before
            joints = self.joints
            dp = pin.difference(model, q, previous)
            Dp = pin.dDifference(model, q, previous, pin.ARG0)
            SD = joints @ Dp
            A += smooth * (SD.T @ SD)
            b -= smooth * (SD.T @ dp)
            c += smooth * float(dp @ joints @ dp)
        if root_pull is not None:  # one view: the root near its constant-velocity path
            weight, predicted = root_pull
            dr = pin.difference(model, q, predicted)
            Dr = pin.dDifference(model, q, predicted, pin.ARG0)
            A += Dr.T @ weight @ Dr
            b -= Dr.T @ (weight @ dr)
            c += float(dr @ weight @ dr)
        for Jg, rg, wg in self._data_rows(i, total, keep):  # the floor's, soles', pins'
            A += Jg.T @ (wg[:, None] * Jg)
            b += Jg.T @ (wg * rg)
            c += float(rg @ (wg * rg))
        return A, b, c

    def _data_rows(self, i: int, total: float, keep: np.ndarray | None = None) -> list:
        """The rows read from ``data`` (at the configuration): the feet on the floor z = 0, the
        soles level (``keep``: the held pulls), one view's second pass's planted feet still."""
        out = []
        if self.soles is not None:
            from .monocular import floor_rows

            out.append(floor_rows(*self.soles(self.data), self.settings.ground * total))
        if self.level is not None and keep is not None:
            out.append(_level_rows(self.model, self.data, *self.level,
                                  self.settings.level * total, keep))  # fmt: skip
        if self.pins is not None:
            from .monocular import STANCE_WEIGHT

            held_rows = self.pins.rows(self.data, i, STANCE_WEIGHT * total)
            if held_rows is not None:
                out.append(held_rows)
        return out

    def placed(self, i, seen, q):
        """``q`` moved onto frame ``i``'s observations (the first frame's start)."""
        model, data = self.model, self.data
        pin.framesForwardKinematics(model, data, q)
        P = np.array([data.oMf[f].act(o) for f, o in zip(self.frames, self.offsets, strict=True)])
        q = q.copy()
        q[:3] += self.obs.place(i, seen, P, self.markers.time[i])
        return q

    def terms(self, i, seen, q):
        """Frame ``i``'s terms (:class:`_Frame`) from ``q``, the observations' rows at ``q``
        and the coordinates no marker sees there (held where they were)."""
        model, previous, time, s = self.model, self.previous, self.markers.time, self.settings
        regularization, smoothing, root_smoothing = s.regularization, s.smoothing, s.root_smoothing
        unseen, hold = s.unseen, s.hold
        total = max(float(np.where(seen, self.weights, 0.0).sum()), 1.0)
        reg = regularization * total
        smooth = 0.0
        if previous is not None and smoothing:  # a pull on the joints' velocity: per 1/dt^2
            dt = abs(float(time[i] - time[self.last]))
            smooth = smoothing * total / dt**2
        # the coordinates no marker sees (at the frame's start): held where they were
        first = self.obs.rows(i, seen, *self.model_markers(q))  # (the first iteration's too)
        column = np.sqrt(first[2] @ first[0] ** 2)
        held_i = column < unseen * column.max()
        keep = np.where(held_i, hold * total, 0.0) if held_i.any() else None  # (diagonal)
        target = previous if previous is not None else self.standing
        root_pull = None
        if self.single and root_smoothing and self.before is not None:
            assert isinstance(self.obs, _Views)  # only views are single
            dt = abs(float(time[i] - time[self.last]))
            predicted = pin.integrate(model, previous, pin.difference(model, self.before,
                                                                      previous))  # fmt: skip
            weight = np.zeros((model.nv, model.nv))
            R = pin.Quaternion(q[6], q[3], q[4], q[5]).toRotationMatrix()
            u = R.T @ self.obs.ray(q[:3])  # the ray through the root, in the root's frame
            weight[:3, :3] = np.outer(u, u) * root_smoothing * total / dt**2
            root_pull = (weight, predicted)
        frame = _Frame(i, seen, reg, keep, target, smooth, previous, total, root_pull)
        return frame, first, held_i

    def fit_frame(self, i, seen, q):
        """Frame ``i`` fitted from ``q``: (q, iterations, converged, held, the frame's terms)."""
        model, eye, box, balls = self.model, self.eye, self.box, self.balls
        s = self.settings
        iterations, tolerance, damping = s.iterations, s.tolerance, s.damping
        frame, first, held_i = self.terms(i, seen, q)
        A, b, c = self.system(q, frame, first)
        extra, grow = 0.0, 2.0  # Levenberg-Marquardt's lambda beyond ``damping``, its growth
        done, it = False, 0
        while it < iterations:
            it += 1
            dq = _bounded_step(A + extra * eye if extra else A, b, q, box, balls)
            step = float(np.abs(dq).max())
            if step < tolerance and (not extra or float(np.abs(
                    _bounded_step(A, b, q, box, balls)).max()) < tolerance):  # fmt: skip
                done = True  # (the step below tolerance is not taken)
                break
            if not extra and float(dq @ (2.0 * b - A @ dq)) <= COST_TOLERANCE * c:
                done = True  # (nor one the model says lowers the cost by less than that)
                break
            q_new = pin.integrate(model, q, dq)
            q_new[box.iq] = np.clip(q_new[box.iq], box.lo, box.hi)  # (rounding)
            new = self.system(q_new, frame)
            down = new[2] <= c + ROUNDING * c  # the cost went down (or by rounding only)
            if down or _inward(balls, q, q_new):  # taken
                small = down and c - new[2] <= COST_TOLERANCE * c
                if down and not small:
                    q_new, dq, new = self.rescaled(q, dq, b, c, q_new, new, frame)
                if extra and down:  # Nielsen's update of lambda from the gain ratio
                    predicted = float(dq @ (2.0 * b - A @ dq))  # (the model's decrease)
                    ratio = min((c - new[2]) / predicted, 1.0) if predicted > 0.0 else 1.0
                    extra *= max(1.0 / 3.0, 1.0 - (2.0 * ratio - 1.0) ** 3)
                    extra = extra if extra > damping else 0.0
                    grow = 2.0
                q, (A, b, c) = q_new, new
                if small:  # (a large residual's slow last steps: the cost no longer moves)
                    done = True
                    break
            else:  # it went up: the step is refused, and shortened
                mean = float(np.trace(A)) / model.nv
                extra = extra * grow if extra else LM_START * mean
                grow *= 2.0
                if extra > LM_GIVE_UP * mean:
                    break
        return q, it, done, held_i, frame

    def rescaled(self, q, dq, b, c, q_new, new, frame):
        """A taken step ``dq`` (to ``q_new``, its system ``new``) tried at another length: a
        large residual's Gauss-Newton model is not the cost's curvature: its steps can
        overshoot a valley's floor, zigzagging across it (on an unscaled body's elbow each step
        went about twice too far, and the frame took 50), or fall short. Where the parabola
        through the cost at 0 (with its slope) and at the step puts the minimum elsewhere, the
        step is tried that long; (q, dq, system) of the better."""
        box = self.box
        c_new = new[2]
        slope = -2.0 * float(b @ dq)
        bend = c_new - c - slope
        if bend > 0.0 and slope < 0.0:
            scale = -slope / (2.0 * bend)
            if scale > 1.0 + RESCALE:
                scale = min(scale, MAX_EXTEND, _room(q, dq, box, self.balls))
            if abs(scale - 1.0) > RESCALE:
                q_far = pin.integrate(self.model, q, scale * dq)
                q_far[box.iq] = np.clip(q_far[box.iq], box.lo, box.hi)  # (rounding)
                far = self.system(q_far, frame)
                if far[2] < c_new:
                    return q_far, scale * dq, far
                if self.model_markers.frames_needed:  # (data back at q_new: the floor reads it)
                    return q_new, dq, self.system(q_new, frame)
        return q_new, dq, new

    def cost(self, i, seen, q) -> float:
        """The observations' weighted squared residual of frame ``i`` at ``q``."""
        _, r, w = self.obs.rows(i, seen, *self.model_markers(q))
        return float(r @ (w * r))

    def start(self, i, seen, q, history):
        """Frame ``i``'s start from the frames before (``q`` the last; None: none)."""
        box = self.box
        if q is None:
            return self.placed(i, seen, self.standing)
        if len(history) > 1 and self.balls is None:  # on at the frames before's pace
            q = _extrapolated(self.model, float(self.markers.time[i]), history)
            q[box.iq] = np.clip(q[box.iq], box.lo, box.hi)
        return q

    def wanted(self, q, frame):
        """Where ``q`` would go with every range off if it is at a bound (else None):
        solved again from there (two Gauss-Newton steps: within 0.1 degree of converged on the
        tests' 5-degree excess, at a third of the cost of converging)."""
        box, balls, model = self.box, self.balls, self.model
        at_ball = bool(np.any(_ball_rows(balls, q, model.nv, BALL_AT_LIMIT)[0] < BALL_AT_LIMIT))
        x = q[box.iq]
        if not (at_ball or bool((np.minimum(x - box.lo, box.hi - x) < AT_LIMIT).any())):
            return None
        free = q.copy()
        for _ in range(min(self.settings.iterations, REFIT_STEPS)):
            dq = np.linalg.solve(*self.system(free, frame)[:2])
            free = pin.integrate(model, free, dq)
            if float(np.abs(dq).max()) < self.settings.tolerance:
                break
        return free


def _first_view(fit: _Fit, i: int, seen):
    """One view's first frame: fitted from each of :data:`~humanoid.motion.monocular.
    HEADINGS`, the best (module :mod:`~humanoid.motion.monocular`)."""
    from .monocular import HEADINGS

    tries = []
    for yaw in HEADINGS:
        start = fit.standing.copy()
        start[3:7] = pin.Quaternion(pin.rpy.rpyToMatrix(0.0, 0.0, yaw)).coeffs()
        fitted = fit.fit_frame(i, seen, fit.placed(i, seen, start))
        tries.append((fit.cost(i, seen, fitted[0]), fitted))
    return min(tries, key=lambda x: x[0])[1]


class _Record:
    """A pass's per-frame outcomes (:class:`IKResult`'s arrays)."""

    def __init__(self, n: int, nq: int, nv: int, m: int) -> None:
        self.q = np.zeros((n, nq))
        self.wanted = np.full((n, nq), np.nan)  # the fits with the ranges off, where they acted
        self.held = np.zeros((n, nv), dtype=bool)
        self.residuals = np.full((n, m), np.nan)
        self.iterations = np.zeros(n, dtype=int)
        self.converged = np.zeros(n, dtype=bool)
        self.depth = np.full((n, 3), np.nan)  # one view: the root's depth sd, across sd, distance

    def result(self, fit: _Fit) -> IKResult:
        """The pass's :class:`IKResult`."""
        model, time, balls = fit.model, fit.markers.time, fit.balls
        at_limit = sorted(_limit_reports(model, time, self.q, self.wanted)
                          + _ball_reports(balls, time, self.q, self.wanted),
                          key=lambda r: -r.excess)  # fmt: skip
        result = IKResult(time.copy(), self.q, fit.names, self.residuals, self.iterations,
                          self.converged, at_limit=at_limit,
                          coordinates=joint_labels(model, root=ROOT_VELOCITY), held=self.held,
                          pixels=getattr(fit.obs, "pixels", None))  # fmt: skip
        if fit.single:
            from .monocular import DepthReport

            obs = fit.obs
            assert isinstance(obs, _Views) and result.pixels is not None  # a reprojection
            px = float(np.sqrt(np.nanmean(result.pixels**2)))
            result.depth = DepthReport(obs.cameras[0].name, self.depth[:, 0], self.depth[:, 1],
                                       self.depth[:, 2], px)  # fmt: skip
        return result


def _solve(h, markers, marker_set, settings: _Settings, q0, progress, cameras=None,
           ball_ranges=False, pins=None, backward=False) -> IKResult:  # fmt: skip
    """One pass of the fit over the frames, in order (``backward``: from the last)."""
    fit = _Fit(h, markers, marker_set, settings, cameras, ball_ranges, pins)
    n = len(markers.time)
    rec = _Record(n, fit.model.nq, fit.model.nv, len(fit.names))
    q = None if q0 is None else np.asarray(q0, dtype=float).copy()
    history: list[tuple[float, np.ndarray]] = []  # the last 3 frames solved: (time, q)
    for i in range(n - 1, -1, -1) if backward else range(n):
        seen = fit.obs.seen(i)
        if q is None and fit.single:  # one view: the heading that fits best
            fitted = _first_view(fit, i, seen)
        else:
            fitted = fit.fit_frame(i, seen, fit.start(i, seen, q, history))
        q, rec.iterations[i], rec.converged[i], rec.held[i], frame = fitted
        wanted = fit.wanted(q, frame)
        if wanted is not None:
            rec.wanted[i] = wanted
        if fit.single:  # the root's depth: its sd for one pixel of noise, from the curvature
            assert isinstance(fit.obs, _Views)  # only views are single
            A, _, _ = fit.system(q, frame)  # (data at q)
            J, _, w = fit.obs.rows(i, seen, *fit.model_markers(q))
            rec.depth[i] = fit.obs.root_depth(q, A, J, w)
        rec.residuals[i] = fit.obs.error(i, seen, fit.model_markers(q)[0])
        rec.q[i] = q
        fit.before, fit.previous, fit.last = fit.previous, q.copy(), i
        history = [*history[-2:], (float(markers.time[i]), fit.previous)]
        if progress is not None:
            progress(i)
    return rec.result(fit)
