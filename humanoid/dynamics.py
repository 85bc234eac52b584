"""Equations of motion  M(q) v' + b(q, v) = tau + J^T f,  with b = C(q, v) v + g(q).

The fast path is Pinocchio's: the mass matrix from the Composite Rigid Body Algorithm (CRBA),
the bias forces from the Recursive Newton-Euler Algorithm (RNEA). :func:`projected_newton_euler`
is an independent implementation of the seeds' projected Newton-Euler sums (robot dynamics
lecture, eq. 3.31 and section 3.5), built from per-body Jacobians only:

    M = sum_i  J_Si^T m_i J_Si + J_Ri^T Theta_i J_Ri
    b = sum_i  J_Si^T m_i (dJ_Si v)  +  J_Ri^T (Theta_i (dJ_Ri v) + omega_i x Theta_i omega_i)
    g = sum_i -J_Si^T m_i g0

where J_Si is the world-frame Jacobian of body i's centre of mass, J_Ri its rotational
Jacobian, Theta_i its inertia about the CoM in world axes and g0 the gravity vector. The tests
show both agree to 1e-9.
"""

from __future__ import annotations

import numpy as np
import pinocchio as pin

from .model import Humanoid, check_configuration

__all__ = [
    "bias_forces",
    "centre_of_mass",
    "centre_of_pressure",
    "centroidal_momentum",
    "gravity_forces",
    "kinetic_energy",
    "mass_matrix",
    "potential_energy",
    "projected_newton_euler",
]


# [N] a vertical force under this has no centre of pressure
COP_FORCE = 1e-9


def centre_of_pressure(wrench, height: float = 0.0) -> np.ndarray:
    """Where on the plane z = ``height`` [m] a wrench about the origin (n, 6) [N, N m: force,
    then moment, in one frame's axes] acts as a force and a moment about z alone: (n, 2) [m],
    x and y, the solution of the moment's x and y rows of m = c x f + (0, 0, tz) with
    c = (x, y, height); NaN where the vertical force is under :data:`COP_FORCE` (a pure
    moment, or no load). The one formula of the toolkit's centres of pressure: a plate's, a
    foot's in its sole's axes, the feet's together (the zero-moment point)."""
    w = np.asarray(wrench, dtype=float).reshape(-1, 6)
    f, m = w[:, :3], w[:, 3:]
    ok = np.abs(f[:, 2]) > COP_FORCE
    fz = np.where(ok, f[:, 2], np.nan)
    return np.column_stack([(height * f[:, 0] - m[:, 1]) / fz, (m[:, 0] + height * f[:, 1]) / fz])


def mass_matrix(h: Humanoid, q) -> np.ndarray:
    """Joint-space inertia matrix M(q) [nv x nv] from CRBA, symmetric (both triangles)."""
    q = check_configuration(h, q)
    return pin.crba(h.model, h.data, q).copy()  # the binding fills both triangles


def bias_forces(h: Humanoid, q, v) -> np.ndarray:
    """b(q, v) = C(q, v) v + g(q) [N, N m] from RNEA with zero acceleration."""
    q, v = check_configuration(h, q, v)
    return pin.rnea(h.model, h.data, q, v, np.zeros(h.nv)).copy()


def gravity_forces(h: Humanoid, q) -> np.ndarray:
    """g(q) [N, N m]: the generalised gravity force (RNEA with v = a = 0)."""
    q = check_configuration(h, q)
    return pin.computeGeneralizedGravity(h.model, h.data, q).copy()


def kinetic_energy(h: Humanoid, q, v) -> float:
    """Kinetic energy 0.5 v^T M v [J]."""
    q, v = check_configuration(h, q, v)
    return float(pin.computeKineticEnergy(h.model, h.data, q, v))


def potential_energy(h: Humanoid, q) -> float:
    """Gravitational potential energy -sum m_i g0 . c_i [J] (zero at the world origin)."""
    q = check_configuration(h, q)
    return float(pin.computePotentialEnergy(h.model, h.data, q))


def centre_of_mass(h: Humanoid, q) -> np.ndarray:
    """Whole-body centre of mass in the world frame [m]."""
    q = check_configuration(h, q)
    return pin.centerOfMass(h.model, h.data, q).copy()


def centroidal_momentum(h: Humanoid, q, v) -> tuple[np.ndarray, np.ndarray]:
    """Linear momentum [kg m/s] and angular momentum about the CoM [kg m^2/s], world axes."""
    q, v = check_configuration(h, q, v)
    hg = pin.computeCentroidalMomentum(h.model, h.data, q, v)
    return hg.linear.copy(), hg.angular.copy()


def projected_newton_euler(h: Humanoid, q, v) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """M(q), b(q, v) (without gravity) and g(q) by the seeds' projected Newton-Euler sums.

    Uses only Pinocchio's kinematics (joint placements, body Jacobians, body velocities and
    velocity-product accelerations), not CRBA or RNEA, so it is an independent cross-check.

    Returns:
        ``(M, b, g)`` with ``b = C(q, v) v`` and ``g = g(q)``.
    """
    q, v = check_configuration(h, q, v)
    model = h.model
    data = model.createData()
    pin.forwardKinematics(model, data, q, v, np.zeros(model.nv))  # data.a[i] = dJ_i v (local)
    pin.computeJointJacobians(model, data, q)
    g0 = model.gravity.linear
    M = np.zeros((model.nv, model.nv))
    b = np.zeros(model.nv)
    g = np.zeros(model.nv)
    for i in range(1, model.njoints):
        inertia = model.inertias[i]
        m, c = inertia.mass, inertia.lever
        R = data.oMi[i].rotation
        J = pin.getJointJacobian(model, data, i, pin.ReferenceFrame.LOCAL)
        J_S = R @ (J[:3] - pin.skew(c) @ J[3:])  # CoM velocity, world axes
        J_R = R @ J[3:]  # angular velocity, world axes
        Theta = R @ inertia.inertia @ R.T  # about the CoM, world axes
        vel, acc = data.v[i], data.a[i]
        w, vo = vel.angular, vel.linear
        # Classical acceleration of the CoM at v' = 0, and angular acceleration, world axes.
        a_S = R @ (acc.linear + np.cross(acc.angular, c) + np.cross(w, vo + np.cross(w, c)))
        alpha = R @ acc.angular
        omega = R @ w
        M += m * J_S.T @ J_S + J_R.T @ Theta @ J_R
        b += m * J_S.T @ a_S + J_R.T @ (Theta @ alpha + np.cross(omega, Theta @ omega))
        g -= m * J_S.T @ g0
    return M, b, g
