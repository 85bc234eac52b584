"""The ground contact's step: semi-implicit Euler with the contact impulses of the ground and
of the joint ranges, solved at the velocity level once per step, with the controller's and
the effects' linear spring-dampers taken implicitly."""

from __future__ import annotations

import numpy as np
import pinocchio as pin

from ..constraints.ground import ContactSolver
from ..errors import DivergenceError
from ..linalg import cholesky_lapack

__all__ = ["GroundStep"]


class GroundStep:
    """One velocity-level step of a plant on the ground (:meth:`advance`).

    Attributes:
        found: What the contact solve found in the last step (impulses, points, wrench), or
            None before the first.
        max_penetration: The deepest ground point at the start of any step [m].
    """

    def __init__(self, plant, solver: ContactSolver) -> None:
        self.plant, self.solver = plant, solver
        self.found = None
        self.max_penetration = 0.0
        self._implicit = None  # (controller, number of effects) -> the implicit terms
        self._armed: tuple | None = None  # (dt, K, D, (model with them as armature, data))
        self._eye = np.eye(plant.model.nv)

    def advance(self, t: float, q, v, dt: float):
        """v_free = v + dt a(q, v) without contacts, the contact impulses of the ground and
        of the joint ranges, v+ = v_free + M^-1 J^T lambda, q+ = q (+) dt v+."""
        p = self.plant
        model, data = p.model, p.data
        implicit = self.implicit_terms()
        if implicit is None:
            v_free = v + dt * p.acceleration(t, q, v)
            pin.computeJointJacobians(model, data, q)
            Minv = pin.computeMinverse(model, data, q)
        else:
            K, D = implicit
            tau = p.applied(t, q, v)
            Minv = self._implicit_inverse(t, q, dt, K, D)
            v_free = v + dt * (Minv @ (tau - p.bias(q, v) - dt * (K @ v)))
            p.counters["implicit"] = p.counters.get("implicit", 0) + 1
            pin.computeJointJacobians(model, data, q)
        v_new, found = self.solver.step(q, v_free, dt, Minv, data)
        if implicit is not None:  # the torque the joints applied over the step
            p.joint_torque = p.joint_torque - (dt * (K @ v_new) + D @ (v_new - v))
            p.last = (p.joint_torque, None)
        p.counters["contact_solves"] = p.counters.get("contact_solves", 0) + 1
        if len(found.phi):
            self.max_penetration = max(self.max_penetration, float(-found.phi.min()))
        self.found = found
        return pin.integrate(model, q, dt * v_new), v_new

    def _implicit_inverse(self, t: float, q, dt: float, K, D) -> np.ndarray:
        """(M + dt D + dt^2 K)^-1. Gains on the diagonal alone (joint damping, a posture hold
        joint by joint) are a joint armature: Pinocchio's O(n^2) inverse of a model that
        carries them (M + diag(a))^-1, five times faster than a Cholesky inverse of the sum
        (to 1e-11, tested); other gains, the Cholesky inverse."""
        p = self.plant
        last = self._armed
        if last is None or last[0] != dt or last[1] is not K or last[2] is not D:
            diagonal = not (np.count_nonzero(K - np.diag(np.diag(K)))
                            or np.count_nonzero(D - np.diag(np.diag(D))))  # fmt: skip
            armed = None
            if diagonal:
                model = p.model.copy()
                model.armature = p.model.armature + dt * np.diag(D) + (dt * dt) * np.diag(K)
                armed = (model, model.createData())
            last = self._armed = (dt, K, D, armed)
        if last[3] is not None:
            return pin.computeMinverse(*last[3], q)
        Mt = pin.crba(p.model, p.data, q) + dt * D + (dt * dt) * K
        potrf, potrs = cholesky_lapack()
        factor, info = potrf(Mt, lower=True)
        if info:
            raise DivergenceError(f"the mass matrix with the implicit gains is not "
                                  f"positive definite at t = {t:.6f} s")  # fmt: skip
        return potrs(factor, self._eye, lower=True)[0]

    def implicit_terms(self):
        """(K, D): the stiffness and damping of the controller and effects that say they are
        linear spring-dampers (:meth:`Effect.implicit`: the posture hold), taken implicitly by
        the step, or None if there are none.

        A posture hold tuned on the body standing on its feet is far too stiff for a foot
        alone: when a foot rocks onto its toes, the ankle's gain meets the foot's own inertia,
        a mode of a few kHz that an explicit step of 1 ms cannot follow (a 100 N push at the
        thorax of the balance scene exploded within 40 ms). Taken implicitly,
        (M + dt D + dt^2 K) v+ = M v + dt (tau - b - dt K v) + J^T lambda, every such mode is
        damped at any step. (Cached per number of effects: a test may add some.)"""
        p = self.plant
        key = (p.controller, len(p.effects))
        if self._implicit is not None and self._implicit[0] == key:
            return self._implicit[1]
        nv = p.model.nv
        K, D, any_terms = np.zeros((nv, nv)), np.zeros((nv, nv)), False
        for eff in [p.controller, *p.effects]:
            terms = eff.implicit(nv) if eff is not None else None
            if terms is not None:
                K, D, any_terms = K + terms[0], D + terms[1], True
        self._implicit = (key, (K, D) if any_terms else None)
        return self._implicit[1]
