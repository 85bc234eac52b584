"""The quaternion formulations a scene names (:data:`humanoid.variants.FORMULATIONS`): the
state the integrator advances, its dynamics and its way back to (q, v) after a step.
:data:`FORMULATION` maps the name to its implementation."""

from __future__ import annotations

from collections.abc import Callable

import numpy as np
import pinocchio as pin

from ..constraints import Baumgarte, update_kinematics
from ..constraints.quaternion import CoordinateMap, QuaternionNorm
from ..constraints.solve import ConstrainedAcceleration, stack
from ..integrators import CoordinateSpace, LieGroupSpace

__all__ = ["FORMULATION", "Coordinates", "LieGroup"]


class LieGroup:
    """Quaternions on their Lie group: the state is (q, v) itself."""

    lie_group = True

    def __init__(self, model: pin.Model) -> None:
        self.space = LieGroupSpace(model)

    def dynamics(self, plant) -> Callable:
        return plant.acceleration

    def state(self, q, v):
        """The integrator's state at (q, v)."""
        return q, v

    def configuration(self, x, xd):
        """(q, v) of the integrator's state."""
        return x, xd

    def norm_residual(self, x) -> float:
        return 0.0

    def after_step(self, x, xd, project):
        """The state after a step, projected on the constraints if ``project`` is given:
        (x, xd, q, v)."""
        if project is not None:
            x, xd = project(x, xd)
        return x, xd, x, xd


class Coordinates:
    """The seeds' coordinate formulation: the state is (x, x'), the quaternions' four numbers
    as coordinates and their unit norm a constraint."""

    lie_group = False

    def __init__(self, model: pin.Model) -> None:
        self.cmap = CoordinateMap(model)
        self.norm = QuaternionNorm(self.cmap)
        self.space = CoordinateSpace(model.nq)

    def dynamics(self, plant) -> Callable:
        return lambda t, x, xdot: self.acceleration(plant, t, x, xdot)

    def state(self, q, v):
        return self.cmap.from_tangent(q, v)

    def configuration(self, x, xd):
        return self.cmap.configuration(x), self.cmap.H(x) @ xd

    def norm_residual(self, x) -> float:
        """| |Q|^2 - 1 | of the raw state, the largest over the quaternions."""
        return float(np.abs(self.norm.residual(x)).max())

    def after_step(self, x, xd, project):
        cm = self.cmap
        if project is not None:
            x = cm.configuration(x)
            q, v = project(x, cm.H(x) @ xd)
            x, xd = cm.from_tangent(q, v)
        return x, xd, cm.configuration(x), cm.H(x) @ xd

    def acceleration(self, plant, t, x, xdot) -> np.ndarray:
        """d(x')/dt (quaternion norm as a constraint), with the plant's forces and contacts."""
        cm, model, data = self.cmap, plant.model, plant.data
        q = cm.configuration(x)
        H = cm.H(x)
        v = H @ xdot
        tau = plant.applied(t, q, v)
        update_kinematics(model, data, q, v)
        pin.crba(model, data, q)
        M = data.M.copy()
        b = plant.bias(q, v)
        Mx = H.T @ M @ H
        fx = H.T @ (tau - b - M @ cm.Hdot_xdot(x, xdot))
        constraints = plant.book.active_constraints()
        Jc_v, gc = stack(model, data, constraints, v, Baumgarte())
        gc = gc - Jc_v @ cm.Hdot_xdot(x, xdot)
        Jc = Jc_v @ H
        Jn, gn = self.norm.jacobian(x), -self.norm.drift(xdot)
        bg = plant.baumgarte
        if bg.active:
            gn -= 2 * bg.alpha * (Jn @ xdot) + bg.beta**2 * self.norm.residual(x)
            if constraints:
                gc -= 2 * bg.alpha * (Jc @ xdot) + bg.beta**2 * np.concatenate(
                    [c.residual(model, data) for c in constraints]
                )
        J = np.vstack([Jn, Jc])
        gamma = np.concatenate([gn, gc])
        m = J.shape[0]
        K = np.block([[Mx, J.T], [J, np.zeros((m, m))]])
        rhs = np.concatenate([fx, gamma])
        try:
            sol = np.linalg.solve(K, rhs)
        except np.linalg.LinAlgError:
            sol = None
        if sol is None or not np.all(np.isfinite(sol)):  # redundant rows: least squares
            sol = np.linalg.lstsq(K, rhs, rcond=1e-13)[0]
        plant.counters["kkt"] += 1
        plant.last = (plant.joint_torque, None)
        if constraints:
            lam = -sol[cm.nq + self.norm.size :]
            a = H @ sol[: cm.nq] + cm.Hdot_xdot(x, xdot)
            plant.last = (plant.joint_torque,
                          ConstrainedAcceleration(a, lam, 0.0, m, "coordinates"))  # fmt: skip
        return sol[: cm.nq]


# name -> (model -> its implementation); the names are humanoid.variants.FORMULATIONS'
FORMULATION: dict[str, Callable[[pin.Model], LieGroup | Coordinates]] = {
    "lie": LieGroup,
    "coordinates": Coordinates,
}
