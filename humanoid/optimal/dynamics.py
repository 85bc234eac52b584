"""A Pinocchio model's kinematics and dynamics as casadi expressions.

:class:`SymbolicModel` walks the model's kinematic tree once and writes, as casadi ``SX``
expressions of (q, v, a): the joints' placements, spatial velocities and accelerations (the
forward pass of the recursive Newton-Euler algorithm), the inverse dynamics RNEA(q, v, a, f)
with point forces, the mass matrix (the exact Jacobian of RNEA in a), the frames' placements,
velocities and classical accelerations, and the configuration's integration q (+) v on its Lie
group. Everything follows Pinocchio's conventions: spatial vectors are (linear, angular), joint
velocities are expressed in the joint's frame (the free flyer's too), quaternions are stored
(x, y, z, w), and gravity enters as the root's acceleration -g.

Why expressions and not Pinocchio's derivatives through callbacks: IPOPT converges in fewer
iterations with exact second derivatives, and casadi differentiates an expression graph to
any order, evaluates it in one compiled virtual machine per call and lets the problem's
sparsity show; a callback gives first derivatives only (the Hessian by L-BFGS) and crosses
into Python at every evaluation. ``tests/test_optimal_dynamics.py`` checks every quantity
against Pinocchio on random states of each joint type the toolkit loads, to 1e-10.

Supported joints: free flyer, spherical (quaternion), revolute (x, y, z, unaligned; bounded and
unbounded), prismatic (x, y, z, unaligned), translation. Another type is a :class:`ModelError`
naming the joint.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np
import pinocchio as pin

from ..errors import ModelError, OptimalControlError
from ._casadi import ca

__all__ = ["Kinematics", "SymbolicModel"]

# Below this squared angle [rad^2] the exponential maps use their Taylor series (the closed
# forms divide by the angle); the first term left out is below 1e-20.
SMALL_ANGLE2 = 1e-6


def skew(w) -> ca.SX:
    """[w]x: the cross-product matrix of a 3-vector."""
    return ca.vertcat(
        ca.horzcat(0, -w[2], w[1]),
        ca.horzcat(w[2], 0, -w[0]),
        ca.horzcat(-w[1], w[0], 0),
    )


def quaternion_matrix(quat) -> ca.SX:
    """Rotation matrix of a unit quaternion stored (x, y, z, w), as Eigen computes it."""
    x, y, z, w = quat[0], quat[1], quat[2], quat[3]
    return ca.vertcat(
        ca.horzcat(1 - 2 * (y * y + z * z), 2 * (x * y - w * z), 2 * (x * z + w * y)),
        ca.horzcat(2 * (x * y + w * z), 1 - 2 * (x * x + z * z), 2 * (y * z - w * x)),
        ca.horzcat(2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y)),
    )


def quaternion_product(a, b) -> ca.SX:
    """a * b for quaternions stored (x, y, z, w)."""
    va, vb = a[:3], b[:3]
    return ca.vertcat(a[3] * vb + b[3] * va + ca.cross(va, vb), a[3] * b[3] - ca.dot(va, vb))


def _series(t2, closed, coefficients):
    """``closed`` (a function of theta and theta^2), or its Taylor series in theta^2 near 0."""
    taylor = sum(c * t2**k for k, c in enumerate(coefficients))
    return ca.if_else(t2 < SMALL_ANGLE2, taylor, closed(ca.sqrt(t2), t2))


def exp_quaternion(w) -> ca.SX:
    """The unit quaternion of the rotation vector ``w`` [rad] (exp on SO(3))."""
    t2 = ca.dot(w, w)
    s = _series(t2, lambda t, _: ca.sin(t / 2) / t, (0.5, -1.0 / 48.0, 1.0 / 3840.0))
    c = _series(t2, lambda t, _: ca.cos(t / 2), (1.0, -1.0 / 8.0, 1.0 / 384.0))
    return ca.vertcat(s * w, c)


def exp_se3(v, w) -> tuple[ca.SX, ca.SX]:
    """The translation of exp6((v, w)) and the unit quaternion of its rotation."""
    t2 = ca.dot(w, w)
    b = _series(t2, lambda t, t2: (1 - ca.cos(t)) / t2, (0.5, -1.0 / 24.0, 1.0 / 720.0))
    c = _series(t2, lambda t, t2: (t - ca.sin(t)) / (t2 * t), (1.0 / 6, -1.0 / 120, 1.0 / 5040))
    W = skew(w)
    return v + b * (W @ v) + c * (W @ (W @ v)), exp_quaternion(w)


def _aligned(q0, q1) -> ca.SX:
    """q1, or -q1 where it lies in the other hemisphere from q0, as Pinocchio returns the free
    flyer's quaternion (not the spherical joint's); they differ only for rotations over pi."""
    return ca.if_else(ca.dot(q0, q1) < 0, -q1, q1)


def rotation(axis, c, s) -> ca.SX:
    """Rotation about the unit ``axis`` of the angle whose cosine and sine are c and s."""
    a = np.asarray(axis, dtype=float)
    K = np.array([[0, -a[2], a[1]], [a[2], 0, -a[0]], [-a[1], a[0], 0]])
    return ca.SX(np.eye(3)) + s * ca.SX(K) + (1 - c) * ca.SX(K @ K)


@dataclass(frozen=True)
class _Joint:
    """One joint as the recursion needs it: its type, indices and constant data."""

    kind: str  # free, spherical, revolute, unbounded, prismatic, translation
    idx_q: int
    idx_v: int
    nq: int
    nv: int
    axis: tuple[float, float, float] | None
    S: np.ndarray  # motion subspace (6 x nv), local frame


KINDS = {
    "FreeFlyer": "free",
    "Spherical": "spherical",
    "Translation": "translation",
    "RX": "revolute",
    "RY": "revolute",
    "RZ": "revolute",
    "RevoluteUnaligned": "revolute",
    "RUBX": "unbounded",
    "RUBY": "unbounded",
    "RUBZ": "unbounded",
    "RevoluteUnboundedUnaligned": "unbounded",
    "PX": "prismatic",
    "PY": "prismatic",
    "PZ": "prismatic",
    "PrismaticUnaligned": "prismatic",
}


def _joint(jm, name: str) -> _Joint:
    kind = KINDS.get(jm.shortname().removeprefix("JointModel"))
    if kind is None:
        raise ModelError(
            f"joint {name!r} is a {jm.shortname()}: the symbolic model supports free flyer, "
            "spherical, revolute, unbounded revolute, prismatic and translation joints"
        )
    # The motion subspace as Pinocchio computes it (constant in the joint's frame for these
    # types); the one-dof joints' axis is read from it (the bindings do not expose every axis).
    jd = jm.createData()
    jm.calc(jd, jm.lieGroup().neutral)
    S = np.array(jd.S).reshape(6, jm.nv)
    axis = None
    if jm.nv == 1:
        a = S[:3, 0] if kind == "prismatic" else S[3:, 0]
        axis = (float(a[0]), float(a[1]), float(a[2]))
    return _Joint(kind, jm.idx_q, jm.idx_v, jm.nq, jm.nv, axis, S)


@dataclass(frozen=True)
class Kinematics:
    """The forward pass at (q, v, a): per joint (index 0 is the universe), the world placement
    (R, p), the placement in its parent's frame (R_parent, p_parent), and the spatial velocity
    and acceleration (a without gravity) in the joint's frame.
    """

    R: list
    p: list
    R_parent: list
    p_parent: list
    v: list | None  # None when the pass had no velocity
    a: list | None  # None when the pass had no acceleration


class SymbolicModel:
    """The kinematics and dynamics of a Pinocchio model as casadi SX expressions.

    Args:
        model: The Pinocchio model (the toolkit's :attr:`Humanoid.model`, or any).

    Raises:
        ModelError: a joint of a type the symbolic model does not write (see the module).
    """

    def __init__(self, model: pin.Model) -> None:
        self.model = model
        self.nq, self.nv = model.nq, model.nv
        # index 0 is the universe, which has no joint
        self.joints: list[_Joint | None] = [None] + [
            _joint(model.joints[i], model.names[i]) for i in range(1, model.njoints)
        ]
        self.parents = list(model.parents)
        self.placements = [
            (np.array(M.rotation), np.array(M.translation)) for M in model.jointPlacements
        ]
        self.inertias = [
            (float(I.mass), np.array(I.lever), np.array(I.inertia)) for I in model.inertias
        ]
        self.gravity = np.array(model.gravity.linear)

    # -- configuration -------------------------------------------------------------------
    def _joint_transform(self, j: _Joint, qj) -> tuple[ca.SX, ca.SX]:
        zero = ca.SX.zeros(3, 1)
        if j.kind == "free":
            return quaternion_matrix(qj[3:7]), qj[:3]
        if j.kind == "spherical":
            return quaternion_matrix(qj), zero
        if j.kind == "revolute":
            return rotation(j.axis, ca.cos(qj[0]), ca.sin(qj[0])), zero
        if j.kind == "unbounded":
            return rotation(j.axis, qj[0], qj[1]), zero
        if j.kind == "prismatic":
            return ca.SX.eye(3), qj[0] * ca.SX(np.reshape(np.asarray(j.axis), (3, 1)))
        return ca.SX.eye(3), qj[:3]  # translation

    def integrate(self, q, v) -> ca.SX:
        """q (+) v: the configuration reached from q along the constant velocity v in unit
        time, on each joint's Lie group (pin.integrate)."""
        out = []
        for j in self.joints[1:]:
            assert j is not None  # only the universe (index 0) has no joint
            qj, vj = q[j.idx_q : j.idx_q + j.nq], v[j.idx_v : j.idx_v + j.nv]
            if j.kind == "free":
                dp, dquat = exp_se3(vj[:3], vj[3:])
                R = quaternion_matrix(qj[3:7])
                out += [qj[:3] + R @ dp, _aligned(qj[3:7], quaternion_product(qj[3:7], dquat))]
            elif j.kind == "spherical":
                out.append(quaternion_product(qj, exp_quaternion(vj)))
            elif j.kind == "unbounded":
                c, s = ca.cos(vj[0]), ca.sin(vj[0])
                out.append(ca.vertcat(c * qj[0] - s * qj[1], s * qj[0] + c * qj[1]))
            else:
                out.append(qj + vj)
        return ca.vertcat(*out)

    # -- kinematics ----------------------------------------------------------------------
    def kinematics(self, q, v=None, a=None) -> Kinematics:
        """The forward pass: placements, and velocities and accelerations when given."""
        n = len(self.joints)
        # filled below for every joint; index 0 is the universe
        R: list[Any] = [ca.SX.eye(3)] + [None] * (n - 1)
        p: list[Any] = [ca.SX.zeros(3, 1)] + [None] * (n - 1)
        R_parent: list[Any] = [None] * n
        p_parent: list[Any] = [None] * n
        vel: list[Any] | None = [ca.SX.zeros(6, 1)] + [None] * (n - 1) if v is not None else None
        acc: list[Any] | None = [ca.SX.zeros(6, 1)] + [None] * (n - 1) if a is not None else None
        for i in range(1, n):
            j, lam = self.joints[i], self.parents[i]
            assert j is not None  # only the universe (index 0) has no joint
            Rj, pj = self._joint_transform(j, q[j.idx_q : j.idx_q + j.nq])
            Rp, pp = self.placements[i]
            Rl, pl = ca.SX(Rp) @ Rj, ca.SX(Rp) @ pj + ca.SX(pp)  # liMi
            R_parent[i], p_parent[i] = Rl, pl
            R[i], p[i] = R[lam] @ Rl, R[lam] @ pl + p[lam]
            if vel is None:
                continue
            S = ca.SX(j.S)
            vj = S @ v[j.idx_v : j.idx_v + j.nv]
            vel[i] = motion_act_inv(Rl, pl, vel[lam]) + vj
            if acc is not None:
                acc[i] = (
                    motion_act_inv(Rl, pl, acc[lam])
                    + S @ a[j.idx_v : j.idx_v + j.nv]
                    + motion_cross(vel[i], vj)
                )
        return Kinematics(R, p, R_parent, p_parent, vel, acc)

    def frame(self, name_or_id) -> tuple[int, np.ndarray, np.ndarray]:
        """A frame's parent joint and its placement (R, p) in that joint's frame."""
        if isinstance(name_or_id, str) and self.model.existFrame(name_or_id):
            fid = self.model.getFrameId(name_or_id)
        elif isinstance(name_or_id, int) and 0 <= name_or_id < len(self.model.frames):
            fid = name_or_id
        else:
            raise ModelError(f"the model has no frame {name_or_id!r}")
        f = self.model.frames[fid]
        return f.parentJoint, np.array(f.placement.rotation), np.array(f.placement.translation)

    def frame_placement(self, kin: Kinematics, frame) -> tuple[ca.SX, ca.SX]:
        """World rotation and position of a frame."""
        i, Rf, pf = self.frame(frame)
        return kin.R[i] @ ca.SX(Rf), kin.R[i] @ ca.SX(pf) + kin.p[i]

    def frame_velocity(self, kin: Kinematics, frame) -> ca.SX:
        """The frame's spatial velocity in its world-aligned frame (linear: the velocity of its
        origin in world axes; angular: the world angular velocity)."""
        if kin.v is None:
            raise OptimalControlError("frame_velocity needs kinematics(q, v), at a velocity")
        i, Rf, pf = self.frame(frame)
        v = kin.v[i]
        lin = v[:3] + ca.cross(v[3:], ca.SX(pf))
        return ca.vertcat(kin.R[i] @ lin, kin.R[i] @ v[3:])

    def frame_acceleration(self, kin: Kinematics, frame) -> ca.SX:
        """The classical (second time derivative) acceleration of the frame's origin, in world
        axes."""
        if kin.v is None or kin.a is None:
            raise OptimalControlError(
                "frame_acceleration needs kinematics(q, v, a), at an acceleration"
            )
        i, Rf, pf = self.frame(frame)
        v, a = kin.v[i], kin.a[i]
        P = ca.SX(pf)
        lin_v = v[:3] + ca.cross(v[3:], P)
        lin_a = a[:3] + ca.cross(a[3:], P)
        return kin.R[i] @ (lin_a + ca.cross(v[3:], lin_v))

    # -- dynamics ------------------------------------------------------------------------
    def rnea(self, q, v, a, point_forces=()) -> ca.SX:
        """Generalised forces tau = M(q) a + b(q, v) - sum_p J_p(q)^T f_p.

        Args:
            q, v, a: Configuration, velocity and acceleration (casadi or numbers).
            point_forces: (frame, force) pairs: a force [N] in world axes applied at a
                frame's origin (a contact point).
        """
        kin = self.kinematics(q, v, a)
        assert kin.v is not None and kin.a is not None  # given v and a, the pass fills both
        n = len(self.joints)
        g = ca.SX(np.reshape(self.gravity, (3, 1)))
        f: list[Any] = [None] * n
        for i in range(1, n):
            m, c, Ic = self.inertias[i]
            ag = kin.a[i] + ca.vertcat(-kin.R[i].T @ g, ca.SX.zeros(3, 1))
            f[i] = inertia_mul(m, c, Ic, ag) + force_cross(
                kin.v[i], inertia_mul(m, c, Ic, kin.v[i])
            )
        for frame, force in point_forces:
            i, _, pf = self.frame(frame)
            fl = kin.R[i].T @ force
            f[i] = f[i] - ca.vertcat(fl, ca.cross(ca.SX(pf), fl))
        tau: list[Any] = [None] * n
        for i in range(n - 1, 0, -1):
            j, lam = self.joints[i], self.parents[i]
            assert j is not None  # only the universe (index 0) has no joint
            tau[i] = ca.SX(j.S).T @ f[i]
            if lam > 0:
                f[lam] = f[lam] + force_act(kin.R_parent[i], kin.p_parent[i], f[i])
        return ca.vertcat(*tau[1:])

    def mass_matrix(self, q) -> ca.SX:
        """M(q), the exact Jacobian of RNEA in the acceleration."""
        a = ca.SX.sym("a", self.nv)
        zero = ca.SX.zeros(self.nv, 1)
        return ca.substitute(ca.jacobian(self.rnea(q, zero, a), a), a, zero)


def motion_act_inv(R, p, m) -> ca.SX:
    """M^-1 . m for M = (R, p) and a motion (linear, angular)."""
    lin, ang = m[:3], m[3:]
    return ca.vertcat(R.T @ (lin - ca.cross(p, ang)), R.T @ ang)


def force_act(R, p, f) -> ca.SX:
    """M . f for M = (R, p) and a force (linear, angular)."""
    fl = R @ f[:3]
    return ca.vertcat(fl, R @ f[3:] + ca.cross(p, fl))


def motion_cross(m1, m2) -> ca.SX:
    """m1 x m2 for motions."""
    return ca.vertcat(ca.cross(m1[3:], m2[:3]) + ca.cross(m1[:3], m2[3:]), ca.cross(m1[3:], m2[3:]))


def force_cross(m, f) -> ca.SX:
    """m x* f: a motion acting on a force."""
    return ca.vertcat(ca.cross(m[3:], f[:3]), ca.cross(m[3:], f[3:]) + ca.cross(m[:3], f[:3]))


def inertia_mul(mass: float, lever: np.ndarray, Ic: np.ndarray, m) -> ca.SX:
    """The spatial inertia (mass, CoM lever, rotational inertia about the CoM) times a
    motion."""
    c = ca.SX(np.reshape(lever, (3, 1)))
    lin = mass * (m[:3] - ca.cross(c, m[3:]))
    return ca.vertcat(lin, ca.SX(Ic) @ m[3:] + ca.cross(c, lin))
