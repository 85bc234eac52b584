"""The whole-body controllers' tasks: each a cost w/2 |J dv - a|^2 on the generalised
acceleration dv, its rows J and its right-hand side a a PD law around a reference.

As in mink and pink, a task only says what differs (:meth:`Task.compute`); the QP's objective is
built once (:func:`humanoid.control.qp.whole_body_qp`). Every task reads the controller's
``data`` brought to (q, v) with a zero acceleration by :func:`~humanoid.control.qp.dynamics_terms`
(placements, velocities, the drift accelerations J'v, joint Jacobians) and returns the rows in
world axes at the frame (LOCAL_WORLD_ALIGNED), angular rows after linear ones.
"""

from __future__ import annotations

import functools
from dataclasses import dataclass
from typing import TypeVar

import numpy as np
import pinocchio as pin

from ..errors import ControlError

__all__ = [
    "CentreOfMassTask",
    "ForceTask",
    "FrameTask",
    "MomentumTask",
    "OrientationTask",
    "PostureTask",
    "Task",
    "TaskStack",
    "closest_in_hull",
]

LWA = pin.ReferenceFrame.LOCAL_WORLD_ALIGNED
# a free-flyer body's coordinates of dv: its joints', and the free flyer's own six
DOFS = {"joints": slice(6, None), "root": slice(0, 6)}


class Task:
    """A cost ``weight``/2 |J dv - a|^2 (``weight`` one number, or one per row)."""

    weight: float | np.ndarray

    def compute(self, model, data, q, v) -> tuple[np.ndarray, np.ndarray]:
        """(J, a): the rows on dv and what J dv should be."""
        raise NotImplementedError


# a task handed to TaskStack.add comes back as its own type
T = TypeVar("T", bound=Task)


class TaskStack:
    """The tasks of one control tick, evaluated as they are added (a later task may read what
    an earlier one measured) at the state (q, v) that ``data`` holds."""

    def __init__(self, model, data, q, v) -> None:
        self.model, self.data, self.q, self.v = model, data, q, v
        self.rows: list[np.ndarray] = []
        self.rhs: list[np.ndarray] = []
        self.weights: list[np.ndarray] = []

    def add(self, task: T) -> T:
        J, a = task.compute(self.model, self.data, self.q, self.v)
        self.rows.append(J)
        self.rhs.append(a)
        w = task.weight
        if isinstance(w, float | int):  # (np.broadcast_to costs more than the task)
            self.weights.append(np.full(J.shape[0], float(w)))
        else:
            self.weights.append(np.broadcast_to(np.asarray(w, dtype=float), J.shape[0]))
        return task

    def stacked(self) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """(J, a, w) of every task, one row each."""
        return np.vstack(self.rows), np.concatenate(self.rhs), np.concatenate(self.weights)


@dataclass
class PostureTask(Task):
    """Coordinates of dv (``dofs``: ``"joints"``, or ``"root"`` the free flyer's six) following
    (q_ref, v_ref, a_ref): a = a_ref + kp (q_ref - q) + kd (v_ref - v), the difference taken
    on the configuration manifold. v_ref and a_ref are full (nv) vectors, or None for zero."""

    q_ref: np.ndarray
    kp: float
    kd: float
    weight: float | np.ndarray
    v_ref: np.ndarray | None = None
    a_ref: np.ndarray | None = None
    dofs: str = "joints"

    def __post_init__(self) -> None:
        if self.dofs not in DOFS:
            raise ControlError(f"dofs must be one of {sorted(DOFS)}, got {self.dofs!r}")

    def compute(self, model, data, q, v):
        nv, dofs = model.nv, DOFS[self.dofs]
        e = pin.difference(model, q, self.q_ref)[dofs]
        v_ref = np.zeros(nv) if self.v_ref is None else self.v_ref
        a_ref = 0.0 if self.a_ref is None else self.a_ref[dofs]
        return _rows(nv, self.dofs), a_ref + self.kp * e + self.kd * (v_ref[dofs] - v[dofs])


@functools.lru_cache(maxsize=16)
def _rows(nv: int, dofs: str) -> np.ndarray:
    """The identity's rows of ``dofs`` (read only: built once per size)."""
    out = np.eye(nv)[DOFS[dofs]]
    out.flags.writeable = False
    return out


@dataclass
class CentreOfMassTask(Task):
    """The centre of mass following (c_ref, dc_ref, ddc_ref) [m, m/s, m/s^2] with gains per
    axis or one for all. With ``support`` (k, 2) [m], the horizontal acceleration asked is one
    the support can carry: its centre of pressure c - ddc z / (g + z'') is moved to the
    nearest point of the support's convex hull. After :meth:`compute`, ``c`` and ``dc`` hold
    the measured centre of mass and its velocity."""

    c_ref: np.ndarray
    dc_ref: np.ndarray
    ddc_ref: np.ndarray
    kp: float | np.ndarray
    kd: float | np.ndarray
    weight: float
    support: np.ndarray | None = None
    c: np.ndarray | None = None
    dc: np.ndarray | None = None

    def compute(self, model, data, q, v):
        c = pin.centerOfMass(model, data, q, v, np.zeros(model.nv)).copy()
        dc, drift = data.vcom[0].copy(), data.acom[0].copy()
        self.c, self.dc = c, dc
        ddc = self.ddc_ref + self.kp * (self.c_ref - c) + self.kd * (self.dc_ref - dc)
        if self.support is not None and len(self.support):
            gz = float(np.linalg.norm(model.gravity.linear)) + ddc[2]
            cop = c[:2] - ddc[:2] * c[2] / gz
            ddc[:2] = (c[:2] - closest_in_hull(cop, np.asarray(self.support))) * gz / c[2]
        return pin.jacobianCenterOfMass(model, data, q), ddc - drift


@dataclass
class FrameTask(Task):
    """A frame's pose following (placement, velocity, acceleration): its twist and classical
    acceleration [m/s, rad/s; m/s^2, rad/s^2] in world axes at the frame, zero if None. With
    ``local_angular`` the angular rows are in the frame's own axes, so that a weight per row
    can free its roll, pitch and yaw apart (a stance foot rolls over heel and toes)."""

    frame: int
    placement: pin.SE3
    kp: float
    kd: float
    weight: float | np.ndarray
    velocity: np.ndarray | None = None
    acceleration: np.ndarray | None = None
    local_angular: bool = False

    @classmethod
    def following(cls, model, rdata, frame: int, kp: float, kd: float, weight, shift=None):
        """The frame of a reference whose kinematics ``rdata`` holds (positions, velocities,
        accelerations), moved by ``shift`` (x, y) [m] if given."""
        M_r = rdata.oMf[frame].copy()
        if shift is not None:
            M_r.translation[:2] += shift
        vr = pin.getFrameVelocity(model, rdata, frame, LWA).vector
        ar = pin.getFrameClassicalAcceleration(model, rdata, frame, LWA).vector
        return cls(frame, M_r, kp, kd, weight, vr, ar)

    def compute(self, model, data, q, v):
        fid = self.frame
        J = pin.getFrameJacobian(model, data, fid, LWA)
        vel = pin.getFrameVelocity(model, data, fid, LWA)
        acc = pin.getFrameClassicalAcceleration(model, data, fid, LWA)
        M_f, M_r = data.oMf[fid], self.placement
        v_ref = np.zeros(6) if self.velocity is None else self.velocity
        a = np.zeros(6) if self.acceleration is None else self.acceleration
        R = M_f.rotation
        lin = a[:3] + self.kp * (M_r.translation - M_f.translation) + self.kd * (
            v_ref[:3] - vel.linear)  # fmt: skip
        ang = a[3:] + self.kp * (R @ pin.log3(R.T @ M_r.rotation)) + self.kd * (
            v_ref[3:] - vel.angular)  # fmt: skip
        rhs = np.concatenate([lin - acc.linear, ang - acc.angular])
        if self.local_angular:
            J = np.vstack([J[:3], R.T @ J[3:]])
            rhs[3:] = R.T @ rhs[3:]
        return J, rhs


@dataclass
class OrientationTask(Task):
    """A frame's orientation following ``rotation`` (world angular velocity and acceleration
    [rad/s, rad/s^2], zero if None). With ``tilt_only`` the reference is the frame's own
    heading, upright: its yaw is left free."""

    frame: int
    rotation: np.ndarray | None
    kp: float
    kd: float
    weight: float
    velocity: np.ndarray | None = None
    acceleration: np.ndarray | None = None
    tilt_only: bool = False

    @classmethod
    def following(cls, model, rdata, frame: int, kp: float, kd: float, weight: float):
        """The frame of a reference whose kinematics ``rdata`` holds."""
        return cls(frame, rdata.oMf[frame].rotation.copy(), kp, kd, weight,
                   pin.getFrameVelocity(model, rdata, frame, LWA).angular,
                   pin.getFrameAcceleration(model, rdata, frame, LWA).angular)  # fmt: skip

    def compute(self, model, data, q, v):
        fid = self.frame
        J = pin.getFrameJacobian(model, data, fid, LWA)[3:]
        w = pin.getFrameVelocity(model, data, fid, LWA).angular
        drift = pin.getFrameAcceleration(model, data, fid, LWA).angular
        R = data.oMf[fid].rotation
        R_ref = self.rotation
        if self.tilt_only:
            R_ref = pin.utils.rotate("z", float(np.arctan2(R[1, 0], R[0, 0])))
        w_ref = np.zeros(3) if self.velocity is None else self.velocity
        dw_ref = 0.0 if self.acceleration is None else self.acceleration
        a = dw_ref + self.kp * (R @ pin.log3(R.T @ R_ref)) + self.kd * (w_ref - w)
        return J, a - drift


@dataclass
class MomentumTask(Task):
    """The centroidal angular momentum k [kg m^2/s] (about the centre of mass) brought to
    ``k_ref`` at the rate kd: d/dt k = kd (k_ref - k). At k_ref = 0 it damps the body's
    whole-body spin (a balance task of humanoid controllers)."""

    kd: float
    weight: float
    k_ref: np.ndarray | None = None

    def compute(self, model, data, q, v):
        A = pin.computeCentroidalMap(model, data, q)[3:].copy()
        dA = pin.computeCentroidalMapTimeVariation(model, data, q, v)[3:]
        k = A @ v
        k_ref = np.zeros(3) if self.k_ref is None else self.k_ref
        return A, self.kd * (k_ref - k) - dA @ v


@dataclass
class ForceTask:
    """A cost ``weight``/2 |S f - target|^2 on the loaded points' forces f [body weights], S
    ``rows`` (the identity if None): a pull towards planned forces, or towards a planned split
    of the load between feet."""

    target: np.ndarray | float
    weight: float
    rows: np.ndarray | None = None

    def terms(self, nf: int) -> tuple[np.ndarray, np.ndarray]:
        """(P, q) of the cost over the nf force variables."""
        if self.rows is None:  # S = I: the same numbers without the products by I
            target = np.broadcast_to(np.asarray(self.target, dtype=float), nf)
            return np.diag(np.full(nf, float(self.weight))), -self.weight * target
        S = np.atleast_2d(self.rows)
        target = np.broadcast_to(np.asarray(self.target, dtype=float), S.shape[0])
        return self.weight * S.T @ S, -self.weight * S.T @ target


def _turn(o, a, b) -> float:
    """The z of (a - o) x (b - o): positive when o, a, b turn counter-clockwise."""
    return (a[0] - o[0]) * (b[1] - o[1]) - (a[1] - o[1]) * (b[0] - o[0])


def _hull(pts: np.ndarray) -> np.ndarray:
    """The vertices of the convex hull of 2D points, counter-clockwise (Andrew's monotone
    chain; collinear points dropped: a segment's two ends, or one point). A support has a few
    points: this is a fifth of Qhull's call."""
    p = sorted({(float(x), float(y)) for x, y in pts})
    if len(p) < 3:
        return np.array(p)

    def half(seq):
        out: list[tuple[float, float]] = []
        for c in seq:
            while len(out) > 1 and _turn(out[-2], out[-1], c) <= 0.0:
                out.pop()
            out.append(c)
        return out[:-1]

    return np.array(half(p) + half(reversed(p)))


def closest_in_hull(p: np.ndarray, pts: np.ndarray) -> np.ndarray:
    """The point of the convex hull of 2D points ``pts`` nearest to p (p itself if inside, to
    1e-12 m)."""
    a = _hull(pts)
    if len(a) == 1:
        return a[0].copy()
    ab = np.roll(a, -1, axis=0) - a
    ap = p - a
    length = np.sqrt((ab * ab).sum(axis=1))
    if len(a) > 2 and np.all(ab[:, 0] * ap[:, 1] - ab[:, 1] * ap[:, 0] >= -1e-12 * length):
        return p
    u = np.clip((ap * ab).sum(axis=1) / (length * length), 0.0, 1.0)
    x = a + u[:, None] * ab
    return x[np.argmin(((x - p) ** 2).sum(axis=1))]
