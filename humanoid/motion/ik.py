"""Inverse kinematics: the body's configurations that best fit measured markers or keypoints.

Each frame solves ``min_q sum_i w_i |p_i(q) - m_i|^2`` over the markers seen in that frame
(``w_i`` the marker set's weights; a marker missing in a frame, NaN, counts for nothing there)
by damped Gauss-Newton on the configuration's Lie group: the step ``dq`` solves
``(J' W J + lambda I) dq = J' W r`` (Pinocchio's frame Jacobians; a marker's Jacobian is its
frame's, moved to the marker), the configuration moves by ``q (+) dq``, and joints with a
range are kept inside it (each step is cut back to the range, the joint then held at its bound
for the rest of the frame's iterations). A small pull towards the standing posture
(``regularization``) settles what the markers cannot see (a spine of two joints seen only at
its ends, a hand without markers). Frames are solved in order, each from the one before; the
first from the standing posture moved onto the markers' centroid.

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

import numpy as np
import pinocchio as pin

from ..errors import HumanoidError
from .inverse_dynamics import joint_labels
from .markers import Marker, MarkerTrajectories

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
AT_LIMIT = 1e-6  # [rad]: a joint this close to its range's bound is at it
ROOT_VELOCITY = ("tx", "ty", "tz", "rx", "ry", "rz")  # the root's coordinates' names' suffixes
REFIT_STEPS = 2  # Gauss-Newton steps of a frame at a bound, solved again with the ranges off
PAST_LIMIT = math.radians(0.1)  # a joint at its bound is held there if the markers want this more


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

    @property
    def unconstrained(self) -> list[str]:
        """The coordinates no marker saw in at least one frame (held there)."""
        if self.held is None:
            return []
        return [c for c, h in zip(self.coordinates, self.held.any(axis=0), strict=True) if h]

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
    names = {model.joints[j].idx_q: model.names[j] for j in range(1, model.njoints)}
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
    for j in range(1, model.njoints):
        joint = model.joints[j]
        if joint.nq == 1 and joint.nv == 1:
            lo, hi = model.lowerPositionLimit[joint.idx_q], model.upperPositionLimit[joint.idx_q]
            if math.isfinite(lo) and math.isfinite(hi) and hi > lo:
                out.append((joint.idx_v, joint.idx_q, float(lo), float(hi)))
    return out


def _bounded_step(A, b, q, ranges) -> np.ndarray:
    """The step minimising 1/2 dq'A dq - b'dq with every ranged joint kept in its range: the
    unconstrained one if it stays inside, else ProxQP's box-constrained solve."""
    dq = np.linalg.solve(A, b)
    if not ranges:
        return dq
    iv = np.array([r[0] for r in ranges])
    x = q[[r[1] for r in ranges]]
    lo = np.array([r[2] for r in ranges]) - x
    hi = np.array([r[3] for r in ranges]) - x
    if np.all(dq[iv] >= lo - 1e-12) and np.all(dq[iv] <= hi + 1e-12):
        return dq
    import proxsuite

    C = np.zeros((len(iv), len(b)))
    C[np.arange(len(iv)), iv] = 1.0
    res = proxsuite.proxqp.dense.solve(A, -b, None, None, C, np.minimum(lo, 0.0),
                                       np.maximum(hi, 0.0), eps_abs=1e-10)  # fmt: skip
    return np.asarray(res.x)


def inverse_kinematics(h, markers: MarkerTrajectories, marker_set: dict[str, Marker], *,
                       register: bool = False, static: MarkerTrajectories | None = None,
                       iterations: int = 50, tolerance: float = 1e-6,
                       damping: float = 1e-6,
                       regularization: float = 1e-6, smoothing: float | None = None,
                       unseen: float = 1e-3, hold: float = 1e-2,
                       q0: np.ndarray | None = None,
                       progress=None) -> IKResult:  # fmt: skip
    """Fit the body to measured markers (see the module docstring).

    Args:
        h: The body. markers: Measured trajectories (our axes, metres). marker_set: Where the
            markers are on the body; only the names both have are used.
        register: If the set has technical markers (:class:`~humanoid.motion.markers.Marker`
            ``anatomical=False``), first fit the anatomical ones alone, put each technical
            marker at its mean place on its frame over that fit (OpenSim's scaling moves
            model markers onto a static trial's the same way), then fit all.
        static: Register on this trial (a person standing still, as labs record one before
            walking) instead of on the motion itself.
        iterations: Gauss-Newton iterations per frame at most. tolerance: a frame stops when
            its step is smaller than this [rad or m]. damping: Levenberg's lambda.
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
        progress: Called with the frame index after each frame (a progress bar).

    Warns:
        RangeLimitWarning: joints held at their range's bounds (:attr:`IKResult.at_limit`).
        UnconstrainedWarning: coordinates no marker sees (:attr:`IKResult.unconstrained`).

    Raises:
        HumanoidError: no marker in common, a marker on a frame the body does not have, a frame
            with fewer than 3 markers seen in total for the first frame.
    """
    names = [n for n in markers.names if n in marker_set]
    if smoothing is None:
        smoothing = 0.0 if len(names) >= 40 else SPARSE_SMOOTHING
    technical = [n for n in names if not marker_set[n].anatomical]
    if register and technical and len(technical) < len(names):
        first = {n: (replace(m, weight=0.0, anatomical=False) if n in technical else m)
                 for n, m in marker_set.items()}  # fmt: skip
        source = static if static is not None else markers
        technical = [n for n in technical if n in source.names]
        fit = _solve(h, source, first, iterations, tolerance, damping, regularization,
                     smoothing, unseen, hold, q0,
                     progress if static is None else None)  # fmt: skip
        marker_set = dict(marker_set) | register_markers(h, source, fit.q, marker_set, technical)
        if static is None:
            q0 = fit.q[0]
    result = _solve(h, markers, marker_set, iterations, tolerance, damping, regularization,
                    smoothing, unseen, hold, q0, progress)  # fmt: skip
    result.marker_set = marker_set
    if result.at_limit:
        warnings.warn("inverse kinematics: " + "; ".join(
            r.describe(len(result.time)) for r in result.at_limit),
            RangeLimitWarning, stacklevel=2)  # fmt: skip
    if result.unconstrained:
        counts = result.held.sum(axis=0)
        named = [f"{c} ({counts[k]} of {len(result.time)} frames)"
                 for k, c in enumerate(result.coordinates) if counts[k]]  # fmt: skip
        warnings.warn("inverse kinematics: no marker sees " + ", ".join(named)
                      + "; held at the frame before (the standing posture at first)",
                      UnconstrainedWarning, stacklevel=2)  # fmt: skip
    return result


def register_markers(h, markers: MarkerTrajectories, q: np.ndarray, marker_set: dict,
                     names) -> dict[str, Marker]:  # fmt: skip
    """The markers ``names`` moved to their mean place on their frames over the fitted
    configurations ``q`` (one per frame of ``markers``; frames where a marker is missing do not
    count)."""
    model = h.model
    data = model.createData()
    sums = {n: np.zeros(3) for n in names}
    counts = dict.fromkeys(names, 0)
    cols = {n: markers.names.index(n) for n in names}
    for i, qi in enumerate(q):
        pin.framesForwardKinematics(model, data, qi)
        for n in names:
            p = markers.positions[i, cols[n]]
            if np.all(np.isfinite(p)):
                sums[n] += data.oMf[model.getFrameId(marker_set[n].frame)].actInv(p)
                counts[n] += 1
    out = {}
    for n in names:
        m = marker_set[n]
        offset = sums[n] / counts[n] if counts[n] else np.array(m.offset)
        out[n] = replace(m, offset=tuple(float(x) for x in offset))
    return out


def _solve(h, markers, marker_set, iterations, tolerance, damping, regularization, smoothing,
           unseen, hold, q0, progress) -> IKResult:  # fmt: skip
    model = h.model
    data = model.createData()
    names = [n for n in markers.names if n in marker_set]
    if not names:
        raise HumanoidError(
            f"no marker of {markers.source or 'the trajectories'} is in the marker set "
            f"(the file's: {', '.join(markers.names[:10])}; the set's: "
            f"{', '.join(list(marker_set)[:10])})"
        )
    for n in names:
        if not model.existFrame(marker_set[n].frame):
            raise HumanoidError(f"marker {n!r} is on frame {marker_set[n].frame!r}, which "
                                f"{h.source} does not have")  # fmt: skip
    cols = [markers.names.index(n) for n in names]
    meas = markers.positions[:, cols]
    frames = [model.getFrameId(marker_set[n].frame) for n in names]
    offsets = np.array([marker_set[n].offset for n in names])
    weights = np.array([marker_set[n].weight for n in names])
    ranges = _ranges(model)
    standing = h.standing_configuration()
    n, m = len(markers.time), len(names)
    out_q = np.zeros((n, model.nq))
    wanted = np.full((n, model.nq), np.nan)  # the fits with the ranges off, where they acted
    held = np.zeros((n, model.nv), dtype=bool)
    residuals = np.full((n, m), np.nan)
    iters = np.zeros(n, dtype=int)
    converged = np.zeros(n, dtype=bool)
    q = None if q0 is None else np.asarray(q0, dtype=float).copy()
    eye = np.eye(model.nv)
    joints = np.diag([0.0] * 6 + [1.0] * (model.nv - 6))
    previous = None

    def markers_jacobian(q, i, seen):
        """The stacked marker Jacobian and the residuals (measured - model) at ``q``."""
        pin.computeJointJacobians(model, data, q)
        pin.updateFramePlacements(model, data)
        J = np.zeros((3 * m, model.nv))
        r = np.zeros(3 * m)
        for k in range(m):
            if not seen[k]:
                continue
            M = data.oMf[frames[k]]
            p = M.act(offsets[k])
            Jf = pin.getFrameJacobian(model, data, frames[k], pin.LOCAL_WORLD_ALIGNED)
            J[3 * k : 3 * k + 3] = Jf[:3] - pin.skew(p - M.translation) @ Jf[3:]
            r[3 * k : 3 * k + 3] = meas[i, k] - p
        return J, r

    def system(q, frame, Jr=None):
        """The Gauss-Newton step's ``A dq = b`` at ``q`` in ``frame`` (``Jr``: the markers'
        Jacobian and residuals at ``q``, if known)."""
        i, seen, w3, reg, keep, target, smooth, previous = frame
        J, r = markers_jacobian(q, i, seen) if Jr is None else Jr
        e = pin.difference(model, q, standing)
        A = J.T @ (w3[:, None] * J) + (damping + reg) * eye + keep
        b = J.T @ (w3 * r) + reg * e + keep @ pin.difference(model, q, target)
        if smooth:  # the joints (not the root) held near the frame before
            A += smooth * joints
            b += smooth * (joints @ pin.difference(model, q, previous))
        return A, b

    for i in range(n):
        seen = np.all(np.isfinite(meas[i]), axis=1) & (weights > 0)
        if q is None:
            if seen.sum() < 3:
                raise HumanoidError(
                    f"frame {i} ({markers.time[i]:.3f} s): fewer than 3 markers seen"
                )
            q = standing.copy()
            pin.framesForwardKinematics(model, data, q)
            model_pts = np.array([data.oMf[f].act(o) for f, o in zip(frames, offsets, strict=True)])
            q[:3] += (meas[i, seen] - model_pts[seen]).mean(axis=0)
        w = np.where(seen, weights, 0.0)
        w3 = np.repeat(w, 3)
        reg = regularization * max(float(w.sum()), 1.0)
        smooth = 0.0
        if previous is not None and smoothing:  # a pull on the joints' velocity: per 1/dt^2
            dt = float(markers.time[i] - markers.time[i - 1])
            smooth = smoothing * max(float(w.sum()), 1.0) / dt**2
        # the coordinates no marker sees (at the frame's start): held where they were
        first = markers_jacobian(q, i, seen)  # (the first iteration's too)
        column = np.sqrt(w3 @ first[0] ** 2)
        held[i] = column < unseen * column.max()
        keep = np.diag(np.where(held[i], hold * max(float(w.sum()), 1.0), 0.0))
        target = previous if previous is not None else standing
        frame = (i, seen, w3, reg, keep, target, smooth, previous)

        for it in range(iterations):
            A, b = system(q, frame, first if it == 0 else None)
            dq = _bounded_step(A, b, q, ranges)
            q_new = pin.integrate(model, q, dq)
            for _, iq, lo, hi in ranges:  # (rounding)
                q_new[iq] = min(max(q_new[iq], lo), hi)
            step = float(np.abs(dq).max())
            q = q_new
            iters[i] = it + 1
            if step < tolerance:
                converged[i] = True
                break
        if any(min(q[iq] - lo, hi - q[iq]) < AT_LIMIT for _, iq, lo, hi in ranges):
            free = q.copy()  # the frame solved again, from there, with every range off (two
            # Gauss-Newton steps: within 0.1 degree of converged on the tests' 5-degree excess,
            # at a third of the cost of converging)
            for _ in range(min(iterations, REFIT_STEPS)):
                dq = np.linalg.solve(*system(free, frame))
                free = pin.integrate(model, free, dq)
                if float(np.abs(dq).max()) < tolerance:
                    break
            wanted[i] = free
        pin.framesForwardKinematics(model, data, q)
        for k in range(m):
            if seen[k]:
                residuals[i, k] = float(
                    np.linalg.norm(data.oMf[frames[k]].act(offsets[k]) - meas[i, k])
                )
        out_q[i] = q
        previous = q.copy()
        if progress is not None:
            progress(i)
    return IKResult(markers.time.copy(), out_q, names, residuals, iters, converged,
                    at_limit=_limit_reports(model, markers.time, out_q, wanted),
                    coordinates=joint_labels(model, root=ROOT_VELOCITY), held=held)  # fmt: skip
