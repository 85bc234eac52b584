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

from types import ModuleType, SimpleNamespace

import numpy as np
import pinocchio as pin

from .errors import ModelError
from .model import Humanoid, check_configuration

try:  # the compiled kernels (humanoid/kernels.c)
    from . import kernels as _compiled

    KERNELS: ModuleType | None = _compiled
except ImportError:  # pragma: no cover - the package built without its extension
    KERNELS = None

__all__ = [
    "JOINT_KINDS",
    "TreeDynamics",
    "bias_forces",
    "centre_of_mass",
    "centre_of_pressure",
    "centroidal_momentum",
    "gravity_forces",
    "kernel_tree",
    "kinetic_energy",
    "mass_matrix",
    "potential_energy",
    "projected_newton_euler",
]


# [N] a vertical force under this has no centre of pressure
COP_FORCE = 1e-9

# the joints the compiled kernels place (as kernels.c's J_*): a model with another kind of
# joint keeps the NumPy and Pinocchio paths
JOINT_KINDS = {"JointModelFreeFlyer": 0, "JointModelSpherical": 1, "JointModelRX": 2,
               "JointModelRY": 2, "JointModelRZ": 2, "JointModelRevoluteUnaligned": 2,
               "JointModelPX": 3, "JointModelPY": 3, "JointModelPZ": 3,
               "JointModelPrismaticUnaligned": 3, "JointModelRUBX": 4, "JointModelRUBY": 4,
               "JointModelRUBZ": 4, "JointModelRevoluteUnboundedUnaligned": 4}  # fmt: skip


def _joint_axis(jm) -> np.ndarray:
    """A revolute or prismatic joint's unit axis in its frame (zero for the others)."""
    name = jm.shortname()
    if name[-1] in "XYZ" and ("JointModelR" in name or "JointModelP" in name):
        return np.eye(3)["XYZ".index(name[-1])]
    if "Unaligned" in name:
        return np.asarray(jm.extract().axis, dtype=float)
    return np.zeros(3)


def kernel_tree(model: pin.Model) -> list[np.ndarray] | None:
    """The compiled kernels' copy of a model's tree: its parents, joint kinds
    (:data:`JOINT_KINDS`), configuration and velocity indices (int64), joint axes (nj, 3) and
    joint placements (nj, 12: rotation row-major, translation); None if a joint is of a kind
    the kernels do not place."""
    kinds = [JOINT_KINDS.get(jm.shortname(), -1) for jm in model.joints]
    if min(kinds[1:], default=0) < 0:
        return None
    place = np.array([np.concatenate([M.rotation.ravel(), M.translation])
                      for M in model.jointPlacements])  # fmt: skip
    ints = [np.array(model.parents), kinds, [jm.idx_q for jm in model.joints],
            [jm.idx_v for jm in model.joints]]  # fmt: skip
    return [*(np.ascontiguousarray(a, dtype=np.int64) for a in ints),
            np.ascontiguousarray([_joint_axis(jm) for jm in model.joints], dtype=float),
            np.ascontiguousarray(place, dtype=float)]  # fmt: skip


class TreeDynamics:
    """Many states' kinematics and inverse dynamics in one compiled call (kernels.c's
    ``tree_dynamics``): each joint's world placement and its body's angular velocity, the
    force each joint carries (RNEA's, without external forces: the moment about the joint's
    origin and the force, world axes) and the generalised forces tau = M a + b. The same
    numbers as Pinocchio's forward kinematics and RNEA to 1e-9 (tests/test_kernels.py), a
    hundredth of the cost of calling them state by state from Python.

    ``available`` is False when the kernels are not built or a joint is of a kind they do not
    place (then use Pinocchio).

    Args:
        model: The Pinocchio model (its gravity is the one used).
    """

    def __init__(self, model: pin.Model) -> None:
        self.model = model
        tree = kernel_tree(model) if KERNELS is not None else None
        self.available = tree is not None
        self._plan = None
        if tree is not None and KERNELS is not None:
            i64, none = np.int64, np.zeros(0)
            # a ground plan without candidate points: the tree alone
            empty = [np.zeros(0, dtype=i64)] * 3 + [none] * 3 + [np.zeros(0, dtype=i64)] * 2
            self._plan = KERNELS.ground_plan(model.njoints, model.nq, model.nv, 0, 0, 0, 1, 0.0,
                                             0.0, *tree, *empty, none)  # fmt: skip
        self._inertia = np.ascontiguousarray([
            np.concatenate([[I.mass], I.lever, I.inertia.ravel()]) for I in model.inertias
        ])  # fmt: skip

    def __call__(self, q, v, a) -> SimpleNamespace:
        """At the states (q, v, a) (n, nq), (n, nv), (n, nv): ``R`` (n, nj, 3, 3) and ``t``
        (n, nj, 3) the joints' placements, ``w`` (n, nj, 3) their bodies' angular
        velocities, ``m`` and ``f`` (n, nj, 3) the moment about each joint's origin and the
        force it carries, world axes (the root's zero), ``tau`` (n, nv)."""
        if self._plan is None or KERNELS is None:
            raise ModelError(f"{self.model.name or 'the model'}: TreeDynamics is not available "
                             "(the kernels are not built, or a joint is of a kind they do not "
                             "place)")  # fmt: skip
        model = self.model
        q, v, a = (np.ascontiguousarray(x, dtype=float) for x in (q, v, a))
        n, nj = len(q), model.njoints
        out = SimpleNamespace(R=np.empty((n, nj, 3, 3)), t=np.empty((n, nj, 3)),
                              w=np.empty((n, nj, 3)), m=np.empty((n, nj, 3)),
                              f=np.empty((n, nj, 3)), tau=np.empty((n, model.nv)))  # fmt: skip
        KERNELS.tree_dynamics(self._plan, n, self._inertia,
                              np.ascontiguousarray(model.gravity.linear), q, v, a, out.R, out.t,
                              out.w, out.m, out.f, out.tau)  # fmt: skip
        return out

    def held(self, q, v, dv, ints: np.ndarray, reals: np.ndarray, tau: np.ndarray) -> int:
        """The welded walk's torques between its QP ticks into ``tau`` (kernels.c's
        ``held_torques``, the holds packed by
        :meth:`~humanoid.walking.controller.HeldForces.hold`), under the model's gravity now:
        0 when written, 1 or 2 when the caller must compute them itself (rows without a
        Cholesky factor, a weld turned within 0.1 rad of pi)."""
        if self._plan is None or KERNELS is None:
            return 3
        gravity = np.ascontiguousarray(self.model.gravity.linear, dtype=float)
        return int(KERNELS.held_torques(self._plan, self._inertia, gravity, q, v, dv, ints, reals,
                                        tau))  # fmt: skip

    @staticmethod
    def rows_of(packed: tuple[np.ndarray, np.ndarray], baumgarte) -> tuple:
        """Welds and joint locks packed by :func:`humanoid.constraints.foot.packed_rows` made
        ready for :meth:`constraint_rows` with the Baumgarte gains ``baumgarte``
        (:class:`~humanoid.constraints.solve.Baumgarte`): their count in front, their rows
        counted, the gains."""
        ints, reals = packed
        m = sum(6 if kind == 0 else 1 for kind in ints[::3].tolist())
        counted = np.concatenate([[len(ints) // 3], ints]).astype(np.int64)
        return counted, reals, m, baumgarte.alpha, baumgarte.beta

    def constraint_rows(self, q, v, rows: tuple) -> tuple[np.ndarray, np.ndarray] | None:
        """The Jacobian rows J and gamma = -(J'v + 2 alpha J v + beta^2 e) of welds and joint
        locks (:meth:`rows_of`) at (q, v): what :func:`humanoid.constraints.solve.stack`
        gives them (to 1e-12), in one compiled call; None without the kernels or when a weld
        is turned within 0.1 rad of pi from its anchor (stack them then)."""
        if self._plan is None or KERNELS is None:
            return None
        ints, reals, m, alpha, beta = rows
        J, gamma = np.empty((m, self.model.nv)), np.empty(m)
        if KERNELS.constraint_rows(self._plan, q, v, ints, reals, alpha, beta, J, gamma) < 0:
            return None
        return J, gamma


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
