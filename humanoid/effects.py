"""Effects: generalised forces that a scene adds only if it asks for them.

Each :class:`Effect` returns a generalised force [N, N m] of size nv, added to tau. Gravity and
the Coriolis/centrifugal terms are not Effects: they live in the bias b(q, v), which the
simulator computes only as far as the scene needs (see :mod:`humanoid.simulate`). Joint torques
of effects and controllers never act on the 6 free-flyer coordinates: :func:`joint_mask` is
applied to them. ``external`` effects (pushes) are forces from outside the body: they enter as
J(q)^T f on every row, the free flyer's included, and are never masked.
"""

from __future__ import annotations

from abc import ABC, abstractmethod

import numpy as np
import pinocchio as pin

__all__ = [
    "Effect",
    "JointDamping",
    "JointLimits",
    "JointSprings",
    "PostureController",
    "Push",
    "joint_mask",
]


TIME_EPS = 1e-9  # [s] far below any time step


def joint_mask(model: pin.Model) -> np.ndarray:
    """1.0 on the actuated (non-root) velocity coordinates, 0.0 on the free-flyer's six."""
    mask = np.ones(model.nv)
    root = model.joints[1]
    mask[root.idx_v : root.idx_v + root.nv] = 0.0
    return mask


class Effect(ABC):
    """A generalised force of a scene. ``velocity_dependent`` effects read v; ``external``
    ones are applied by the world (J^T f on every row), the others by the joints."""

    name: str = "effect"
    velocity_dependent: bool = False
    external: bool = False

    @abstractmethod
    def force(self, model: pin.Model, data: pin.Data, t: float, q, v) -> np.ndarray | None:
        """Generalised force [N, N m], shape (nv,), or None when the effect adds nothing at
        (t, q, v) (a push outside its window, every joint inside its range)."""

    def implicit(self, nv: int) -> tuple[np.ndarray, np.ndarray] | None:
        """The effect's stiffness and damping, K = -d(force)/dq and D = -d(force)/dv, as
        constant (nv, nv) matrices, for a step that takes them implicitly (the ground contact's
        velocity-level step); None if the effect is not a linear spring-damper."""
        return None


class JointDamping(Effect):
    """tau = -c v on the joints [c in N m s/rad].

    Taken implicitly on the ground contact's step (:meth:`implicit`): one coefficient for
    every joint meets the toes' own inertia (1e-4 kg m^2), c dt / I = 5 at 0.5 N m s/rad and
    1 ms, where an explicit step amplifies the toes' motion every step (the drop scene's feet
    spun to 26 m/s in its fall and met the floor 14 mm deep)."""

    name = "damping"
    velocity_dependent = True

    def __init__(self, model: pin.Model, coefficient: float) -> None:
        self.c = coefficient * joint_mask(model)

    def force(self, model, data, t, q, v):
        return -self.c * v

    def implicit(self, nv):
        return np.zeros((nv, nv)), np.diag(self.c)


class JointSprings(Effect):
    """tau = -k (q - q_rest) on the joints, the difference taken on the Lie group [k N m/rad]."""

    name = "springs"

    def __init__(self, model: pin.Model, stiffness: float, rest: np.ndarray) -> None:
        self.k = stiffness * joint_mask(model)
        self.rest = np.array(rest, dtype=float)

    def force(self, model, data, t, q, v):
        return -self.k * pin.difference(model, self.rest, q)


class JointLimits(Effect):
    """A stiff spring-damper that pushes every joint back inside its range.

    Each range row r(q) >= 0 of :class:`~humanoid.constraints.limits.JointRanges` (a hinge's
    limits; a ball joint's triplet angles) that is violated (r < 0) pushes back with
    f = -k r - c min(J v, 0) along its row: tau = J^T f (the damping only resists motion
    further out). On a hinge this is tau_j = -k (q_j - limit) - c v_j beyond a limit. Inside
    every range it is zero; beyond one it is the gradient of the potential k r^2 / 2 plus a
    dissipative term, so it never adds energy.

    Args:
        h: The :class:`~humanoid.model.Humanoid` (its ball joints' ranges come from its
            fusion).
        stiffness: k [N m/rad]. damping: c [N m s/rad].
    """

    name = "joint_limits"
    velocity_dependent = True

    def __init__(self, h, stiffness: float, damping: float) -> None:
        from .constraints.limits import JointRanges

        self.ranges = JointRanges(h)
        self.k, self.c = stiffness, damping

    def force(self, model, data, t, q, v):
        r, J = self.ranges.rows(q, margin=0.0)
        if not len(r):
            return None
        f = -self.k * r - self.c * np.minimum(J @ v, 0.0)
        return J.T @ f

    def violation(self, q) -> float:
        """Largest excursion beyond a range [rad]."""
        return self.ranges.violation(q)


class Push(Effect):
    """An external wrench during [start, start + duration): a force [N] at the origin of a
    frame and a torque [N m], both in world axes.

    It enters the dynamics as J(q)^T (f, tau) with J the frame's Jacobian in world-aligned
    axes (LOCAL_WORLD_ALIGNED: the velocity of the frame origin and the angular velocity, both
    in world axes), on every row including the free flyer's: a free body gains exactly the
    impulse, and about its centre of mass the angular impulse of r x f + tau.
    """

    name = "push"
    external = True

    def __init__(self, frame_id: int, force, start: float, duration: float, torque=None) -> None:
        self.frame_id = frame_id
        self.wrench = np.zeros(6)
        self.wrench[:3] = force
        if torque is not None:
            self.wrench[3:] = torque
        self.start, self.end = start, start + duration

    def active(self, t: float) -> bool:
        """Whether the push acts at t; times within TIME_EPS [s] of an edge count as on it,
        so that a window 0.1 + 0.2 s covers exactly the steps 0.1 <= k dt < 0.3 although
        0.1 + 0.2 > 0.3 in floating point."""
        return self.start <= t + TIME_EPS and t + TIME_EPS < self.end

    def force(self, model, data, t, q, v):
        if not self.active(t):
            return None
        pin.framesForwardKinematics(model, data, q)
        J = pin.computeFrameJacobian(
            model, data, q, self.frame_id, pin.ReferenceFrame.LOCAL_WORLD_ALIGNED
        )
        return J.T @ self.wrench


# Relative cut-off of the pseudo-inverse of the constrained joint-space inverse inertia: the
# directions the contacts block (near-zero eigenvalues) get no gain. With exact (rigid) welds
# they cannot move anyway; with compliant ones (MuJoCo's) huge gains there would explode.
PINV_RCOND = 1e-9


class PostureController(Effect):
    """PD hold of a posture on the joints: tau = tau_ff + Kp (q_ref - q) - Kd v.

    Either absolute gains (``kp`` [N m/rad], ``kd`` [N m s/rad], the same on every joint), or a
    closed-loop ``frequency`` [Hz] and ``damping_ratio``: then the gains are matrices,
    Kp = w^2 L and Kd = 2 zeta w L with w = 2 pi frequency and L the joint-space inertia that
    the body shows through its contacts at q_ref, L = (S A S^T)^+ with S the joint selection
    and A = M^-1 - M^-1 J^T (J M^-1 J^T)^+ J M^-1 the constrained inverse inertia (A = M^-1
    without contacts). Linearised at q_ref, every mode of the held body then has the natural
    frequency w and the damping ratio zeta. Per-joint scalar gains cannot do this on a human:
    equal gains on a 0.4 kg hand and a 30 kg trunk are far too stiff for one and too weak for
    the other, and in a closed chain (both feet on the ground) a light link between stiff
    joints (the pelvis between the hips and the lumbar joint) makes a mode that is stiff even
    when every joint's own gain is modest.

    With contacts, a constant feed-forward holds q_ref in static equilibrium: the joint part of
    g(q_ref) - J^T f, with f the minimum-norm contact forces that balance the base,
    J_base^T f = g_base(q_ref).
    """

    name = "controller"
    velocity_dependent = True

    def __init__(
        self, model, q_ref, kp=0.0, kd=0.0, frequency=0.0, damping_ratio=1.0, contact_jacobian=None
    ):
        mask = joint_mask(model)
        self.joints = np.flatnonzero(mask)
        if np.array_equal(self.joints, np.arange(self.joints[0], model.nv)):
            self.joints = slice(int(self.joints[0]), model.nv)  # contiguous: a view, no gather
        self.q_ref = np.array(q_ref, dtype=float)
        self.feedforward = np.zeros(model.nv)
        J = contact_jacobian if contact_jacobian is not None else np.zeros((0, model.nv))
        if len(J):
            g = pin.computeGeneralizedGravity(model, model.createData(), self.q_ref)
            f = np.linalg.lstsq(J[:, :6].T, g[:6], rcond=None)[0]
            self.feedforward = (g - J.T @ f) * mask
        if frequency > 0:
            A = pin.computeMinverse(model, model.createData(), self.q_ref)
            if len(J):
                AJt = A @ J.T
                A = A - AJt @ np.linalg.pinv(J @ AJt, rcond=1e-10) @ AJt.T
            L = np.linalg.pinv(A[self.joints][:, self.joints], rcond=PINV_RCOND, hermitian=True)
            w = 2.0 * np.pi * frequency
            self.kp, self.kd = w**2 * L, 2.0 * damping_ratio * w * L
        else:
            n = int(mask.sum())
            self.kp, self.kd = kp * np.eye(n), kd * np.eye(n)
        self._gains = np.hstack([self.kp, self.kd])
        self._x = np.zeros(2 * len(self.kp))

    def before_step(self, sim, k: int, t: float, q, v) -> None:
        """A controller's hook before each step: the hold has nothing to update."""

    def force(self, model, data, t, q, v):
        # tau_j = ff_j + Kp e_j - Kd v_j as one product: [Kp, Kd] @ [e_j; -v_j]
        x = self._x
        n = len(x) // 2
        x[:n] = pin.difference(model, q, self.q_ref)[self.joints]
        np.negative(v[self.joints], out=x[n:])
        tau = self.feedforward.copy()
        tau[self.joints] += self._gains @ x
        return tau

    def implicit(self, nv):
        K, D = np.zeros((nv, nv)), np.zeros((nv, nv))
        j = (
            (self.joints,) * 2
            if isinstance(self.joints, slice)
            else np.ix_(self.joints, self.joints)
        )
        K[j], D[j] = self.kp, self.kd
        return K, D
