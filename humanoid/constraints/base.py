"""The constraint interface: a residual e(q), its Jacobian J(q) and the drift J'(q, v) v.

A constraint with ``size`` rows asks e(q) = 0. Differentiated twice, it becomes the
acceleration-level row block of the KKT system

    J(q) a + J'(q, v) v = 0        (plus optional Baumgarte terms  2 alpha J v + beta^2 e).

Every method reads the kinematics that :func:`update_kinematics` has put into ``data`` for the
current (q, v), so that several constraints share one pass over the tree.
"""

from __future__ import annotations

from abc import ABC, abstractmethod

import numpy as np
import pinocchio as pin

__all__ = ["Constraint", "update_kinematics"]


def update_kinematics(model: pin.Model, data: pin.Data, q: np.ndarray, v: np.ndarray) -> None:
    """Placements, velocities, velocity-product accelerations (a = 0) and joint Jacobians."""
    pin.forwardKinematics(model, data, q, v, np.zeros(model.nv))
    pin.computeJointJacobians(model, data, q)
    pin.updateFramePlacements(model, data)


class Constraint(ABC):
    """A holonomic constraint e(q) = 0 on a Pinocchio model.

    Subclasses set ``name`` and ``size`` and implement :meth:`residual`, :meth:`jacobian` and
    :meth:`drift`. :meth:`residual_jacobian` (de/dq in the tangent space, for projection and
    finite-difference tests) defaults to :meth:`jacobian`.
    """

    name: str
    size: int

    @abstractmethod
    def residual(self, model: pin.Model, data: pin.Data) -> np.ndarray:
        """e(q), shape (size,) [m or rad]."""

    @abstractmethod
    def jacobian(self, model: pin.Model, data: pin.Data) -> np.ndarray:
        """J(q), shape (size, nv): the constraint velocity is J v."""

    @abstractmethod
    def drift(self, model: pin.Model, data: pin.Data) -> np.ndarray:
        """J'(q, v) v, shape (size,): the constraint acceleration at a = 0."""

    def residual_jacobian(self, model: pin.Model, data: pin.Data) -> np.ndarray:
        """de/dq along tangent directions, shape (size, nv)."""
        return self.jacobian(model, data)

    def twin(self, model: pin.Model, baumgarte) -> pin.RigidConstraintModel | None:
        """Pinocchio's C++ model of this constraint (the same rows, Jacobian, drift and
        Baumgarte gains), or None if Pinocchio has none: then the native backend solves the
        constraint from :meth:`jacobian` and :meth:`drift` (:mod:`humanoid.constraints.native`).
        """
        return None

    def __repr__(self) -> str:
        return f"{type(self).__name__}({self.name!r}, size={self.size})"
