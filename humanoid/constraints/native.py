"""The constrained forward dynamics solved in Pinocchio's C++: the default backend.

The project's constraints (:mod:`humanoid.constraints`) define every row: its residual e(q),
Jacobian J(q) and drift J'(q, v) v. :func:`~humanoid.constraints.solve.solve_kkt` solves the
KKT system from them in NumPy; it is the reference, readable and exact, but a step then costs
several times Pinocchio's own constrained dynamics in Python overhead. Here the same system is
handed to C++ once per evaluation:

- Constraints that Pinocchio models natively (a welded frame, a pinned point) bring their
  *twin*, a ``pin.RigidConstraintModel`` with the same rows, Jacobian, drift and Baumgarte
  gains (:meth:`~humanoid.constraints.base.Constraint.twin`), built once when the active set
  changes. One ``pin.constraintDynamics`` call then computes the kinematics, M, b, the drift
  and the sparse (tree-structured) Cholesky factorisation of the KKT matrix.
- Any other constraint (a user's own) gives its J and drift, and the dense KKT system is solved
  by ``pin.forwardDynamics(model, data, q, v, tau, J, gamma)``, still in C++.

Sets with redundant rows (four pinned corners per flat foot: 12 rows of rank 6) are solved by
Pinocchio's proximal iterations (mu = 1e-2, to 1e-12), where an exact factorisation would
divide by zero. The twins' equivalence with the reference (J, drift, forces, motion) is tested
in ``tests/test_native.py``.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np
import pinocchio as pin

from ..dynamics import TreeDynamics
from .base import Constraint, update_kinematics
from .foot import packed_rows
from .solve import Baumgarte, split_forces, stack

__all__ = ["NativeSolve", "proximal_settings"]

# Damping of the dense path's Delassus matrix (forwardDynamics): far below any physical
# compliance, enough to keep a redundant row from dividing by zero.
DENSE_DAMPING = 1e-12


def proximal_settings(redundant: bool) -> pin.ProximalSettings:
    """Settings of pin.constraintDynamics: one exact solve, or proximal iterations (mu = 1e-2)
    for redundant sets such as point contacts (12 rows per foot), where mu = 0 gives NaN."""
    if redundant:
        return pin.ProximalSettings(1e-12, 1e-12, 1e-2, 50)
    return pin.ProximalSettings(1e-12, 1e-12, 0.0, 1)


class NativeSolve:
    """A set of active constraints, prepared for Pinocchio's C++ solve (build one per active
    set: the twins and Pinocchio's data are allocated here, not per evaluation).

    Args:
        model: The Pinocchio model (with the scene's gravity).
        constraints: The active constraints.
        baumgarte: Stabilisation gains (the twins' Baumgarte corrector).
        redundant: Whether the rows may be linearly dependent (proximal iterations).
    """

    method = "pinocchio"

    def __init__(
        self,
        model: pin.Model,
        constraints: Sequence[Constraint],
        baumgarte: Baumgarte | None = None,
        redundant: bool = False,
        tree: TreeDynamics | None = None,
    ) -> None:
        baumgarte = baumgarte or Baumgarte()
        self.model = model
        self.source = constraints  # the caller's sequence (its identity tells a new set)
        self.constraints = list(constraints)
        self.baumgarte = baumgarte
        twins = [c.twin(model, baumgarte) for c in self.constraints]
        self.native = all(t is not None for t in twins)
        self.data = model.createData()
        if self.native:
            self.cms = pin.StdVec_RigidConstraintModel()
            for t in twins:
                self.cms.append(t)
            self.cds = pin.StdVec_RigidConstraintData()
            for cm in self.cms:
                self.cds.append(cm.createData())
            pin.initConstraintDynamics(model, self.data, self.cms, self.cds)
            self.prox = proximal_settings(redundant)
        # the dense path's rows in one compiled call when they are welds and locks (``tree``:
        # the model's TreeDynamics, available)
        self._rows = None
        if not self.native and tree is not None and tree.available:
            packed = packed_rows(model, self.constraints)
            if packed is not None:
                self._rows = (tree, tree.rows_of(packed, baumgarte))
        self.a = np.zeros(model.nv)

    def acceleration(self, q: np.ndarray, v: np.ndarray, tau: np.ndarray) -> np.ndarray:
        """The constrained acceleration under ``tau`` (joint torques and external forces as
        generalised forces; gravity and velocity terms are the model's), a new array."""
        if self.native:
            self.a = pin.constraintDynamics(
                self.model, self.data, q, v, tau, self.cms, self.cds, self.prox
            )
        else:
            model, data = self.model, self.data
            rows = None
            if self._rows is not None:
                tree, packed = self._rows
                rows = tree.constraint_rows(q, v, packed)
            if rows is None:
                update_kinematics(model, data, q, v)
                rows = stack(model, data, self.constraints, v, self.baumgarte)
            J, gamma = rows
            # Pinocchio's drift is J'v (J a + drift = 0): our gamma with its sign turned
            self.a = pin.forwardDynamics(model, data, q, v, tau, J, -gamma, DENSE_DAMPING)
        return self.a

    @property
    def forces(self) -> np.ndarray:
        """The constraint forces of the last call (ground on body, in each constraint's axes,
        stacked as the constraints), as :class:`~humanoid.constraints.ConstrainedAcceleration`
        gives them; a new array. Both Pinocchio paths leave the stacked multipliers in
        data.lambda_c (for constraintDynamics: each contact's contact_force)."""
        return np.array(self.data.lambda_c)


class NativeSolution:
    """The result of one :meth:`NativeSolve.acceleration`: the accelerations, and the forces
    read from Pinocchio's data on demand. :meth:`freeze` copies the forces out before the next
    call overwrites that data (an RK stage)."""

    method = "pinocchio"

    def __init__(self, solve: NativeSolve) -> None:
        self._solve = solve
        self.a = solve.a
        self._forces: np.ndarray | None = None

    @property
    def forces(self) -> np.ndarray:
        if self._forces is None:
            self._forces = self._solve.forces
        return self._forces

    def freeze(self) -> None:
        """Copy the forces out of Pinocchio's data now."""
        _ = self.forces

    def split(self, constraints: Sequence[Constraint]) -> dict[str, np.ndarray]:
        return split_forces(self.forces, constraints)
