"""The constrained solves a scene names (:data:`humanoid.variants.BACKENDS`): the
accelerations of the plant with its attached contacts. :data:`CONSTRAINT_BACKENDS` maps the
name to its implementation."""

from __future__ import annotations

import numpy as np
import pinocchio as pin

from ..constraints import solve_kkt, update_kinematics
from ..constraints.native import NativeSolution, NativeSolve
from ..constraints.solve import stack
from ..dynamics import TreeDynamics

__all__ = ["CONSTRAINT_BACKENDS", "Native", "Reference"]


class Reference:
    """The project's KKT solve in NumPy (any formulation, any bias terms)."""

    def __init__(self, plant) -> None:
        self.plant = plant

    @staticmethod
    def supports(setup) -> bool:
        return True

    def __call__(self, q, v, tau, constraints) -> np.ndarray:
        p = self.plant
        update_kinematics(p.model, p.data, q, v)
        Minv = pin.computeMinverse(p.model, p.data, q)
        J, gamma = stack(p.model, p.data, constraints, v, p.baumgarte)
        sol = solve_kkt(Minv, tau - p.bias(q, v), J, gamma)
        p.last = (p.joint_torque, sol)
        return sol.a


class Native:
    """The active set solved in Pinocchio's C++, prepared once per active set
    (:class:`~humanoid.constraints.native.NativeSolve`)."""

    def __init__(self, plant) -> None:
        self.plant = plant
        self.solve: NativeSolve | None = None
        self.tree: TreeDynamics | None = None  # for the dense path's compiled rows, once

    @staticmethod
    def supports(setup) -> bool:
        """It needs the full bias b(q, v) (Pinocchio's) and the Lie-group quaternions: a
        scene without the velocity terms is solved by the reference."""
        return bool(setup.scene.effects.coriolis) and setup.formulation.lie_group

    def __call__(self, q, v, tau, constraints) -> np.ndarray:
        p, solve = self.plant, self.solve
        if solve is None or solve.source is not constraints:
            redundant = sum(c.size for c in constraints) > 6 * len(p.contacts)
            if self.tree is None:
                self.tree = TreeDynamics(p.model)
            solve = self.solve = NativeSolve(p.model, constraints, p.baumgarte, redundant,
                                             self.tree)  # fmt: skip
        a = solve.acceleration(q, v, tau)
        p.last = (p.joint_torque, NativeSolution(solve))
        return a


# name -> its implementation (built per plant); the names are humanoid.variants.BACKENDS'
CONSTRAINT_BACKENDS: dict[str, type[Native] | type[Reference]] = {
    "native": Native,
    "reference": Reference,
}
