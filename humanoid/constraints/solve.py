"""The constrained forward dynamics: the KKT system solved through its Schur complement.

    [ M  J^T ] [  a      ]   [ tau - b                       ]
    [ J  0   ] [ -lambda ] = [ -J'v - 2 alpha J v - beta^2 e ]

M^-1 comes from Pinocchio (``computeMinverse``, a recursive O(n^2) pass that exploits the
tree structure of M), then the Delassus matrix D = J M^-1 J^T (m x m) is factorised:

- by Cholesky when it is well conditioned (the usual case: two welded feet, 12 rows);
- by a symmetric eigendecomposition with a relative cut-off otherwise (redundant rows such as
  four point contacts per flat foot, 24 rows of rank 12, or nearly singular sets such as
  straight knees with both feet welded). This gives the minimum-norm forces and the unique
  accelerations, never NaN; an inconsistent right-hand side gets its least-squares solution.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
import pinocchio as pin

from ..errors import SceneError
from ..linalg import cholesky_lapack
from .base import Constraint, update_kinematics

__all__ = [
    "Baumgarte",
    "ConstrainedAcceleration",
    "constrained_dynamics",
    "impact",
    "solve_kkt",
]

# Relative eigenvalue cut-off of the Delassus matrix below which rows count as redundant.
RANK_TOL = 1e-9
# Cholesky is used while the ratio of smallest to largest squared pivot stays above this.
CHOLESKY_MIN_PIVOT = 1e-8


@dataclass(frozen=True)
class Baumgarte:
    """Baumgarte stabilisation: J a + J'v + 2 alpha J v + beta^2 e = 0.

    Attributes:
        alpha: Velocity gain [1/s].
        beta: Position gain [1/s].
    """

    alpha: float = 0.0
    beta: float = 0.0

    @classmethod
    def from_time_constant(cls, tau: float) -> Baumgarte:
        """Critically damped error dynamics e'' + (2/tau) e' + e / tau^2 = 0, ``tau`` [s]."""
        if not tau > 0:
            raise SceneError(f"Baumgarte time constant must be > 0 s, got {tau}")
        return cls(alpha=1.0 / tau, beta=1.0 / tau)

    @property
    def active(self) -> bool:
        return self.alpha != 0.0 or self.beta != 0.0


@dataclass(frozen=True)
class ConstrainedAcceleration:
    """The solution of one KKT system.

    Attributes:
        a: Generalised acceleration [m/s^2, rad/s^2], shape (nv,).
        forces: Constraint forces lambda (ground on body), stacked as the constraints, (m,).
        residual: max |J a - gamma|, the acceleration-level constraint error.
        rank: Numerical rank of the Delassus matrix J M^-1 J^T.
        method: ``"cholesky"``, ``"eigen"`` (regularised) or ``"none"`` (no constraint).
    """

    a: np.ndarray
    forces: np.ndarray
    residual: float
    rank: int
    method: str

    def split(self, constraints: Sequence[Constraint]) -> dict[str, np.ndarray]:
        """Forces by constraint name."""
        return split_forces(self.forces, constraints)


def split_forces(forces: np.ndarray, constraints: Sequence[Constraint]) -> dict[str, np.ndarray]:
    """Stacked constraint forces, by constraint name."""
    out, i = {}, 0
    for c in constraints:
        out[c.name] = forces[i : i + c.size]
        i += c.size
    return out


def solve_kkt(Minv: np.ndarray, f: np.ndarray, J: np.ndarray, gamma: np.ndarray):
    """Solve M a = f + J^T lambda, J a = gamma, given M^-1.

    Returns:
        :class:`ConstrainedAcceleration`.
    """
    a_free = Minv @ f
    if J.shape[0] == 0:
        return ConstrainedAcceleration(a_free, np.zeros(0), 0.0, 0, "none")
    MJt = Minv @ J.T
    D = J @ MJt
    rhs = gamma - J @ a_free
    lam, rank, method = None, J.shape[0], "cholesky"
    potrf, potrs = cholesky_lapack()
    factor, info = potrf(D)  # LAPACK directly: numpy's wrappers cost more than the work here
    if info == 0:
        pivots = np.diag(factor) ** 2
        if pivots.min() > CHOLESKY_MIN_PIVOT * pivots.max():
            lam = potrs(factor, rhs)[0]
    if lam is None:
        w, V = np.linalg.eigh(D)
        keep = w > RANK_TOL * max(w[-1], 0.0)
        rank, method = int(keep.sum()), "eigen"
        lam = V[:, keep] @ ((V[:, keep].T @ rhs) / w[keep])
    a = a_free + MJt @ lam
    residual = float(np.abs(J @ a - gamma).max())
    return ConstrainedAcceleration(a, lam, residual, rank, method)


def impact(Minv: np.ndarray, J: np.ndarray, v: np.ndarray) -> np.ndarray:
    """The velocity after an inelastic impact on the constraints J: v+ = v + M^-1 J^T Lambda
    with the impulse Lambda that makes J v+ = 0 (the KKT system at the velocity level)."""
    return v + solve_kkt(Minv, np.zeros(len(v)), J, -(J @ v)).a


def constrained_dynamics(
    model: pin.Model,
    data: pin.Data,
    q: np.ndarray,
    v: np.ndarray,
    tau: np.ndarray,
    constraints: Sequence[Constraint],
    baumgarte: Baumgarte = Baumgarte(),
    bias: np.ndarray | None = None,
) -> ConstrainedAcceleration:
    """Accelerations and constraint forces of ``model`` under ``tau`` and ``constraints``.

    Args:
        model, data: Pinocchio model and data.
        q, v: State [q in R^nq, v in R^nv].
        tau: Applied generalised force [N, N m] (controller, effects), shape (nv,).
        constraints: Active constraints (may be empty: then this is plain forward dynamics).
        baumgarte: Stabilisation gains.
        bias: b(q, v) if the caller computed it (e.g. without some effects); RNEA otherwise.

    Returns:
        :class:`ConstrainedAcceleration`.
    """
    update_kinematics(model, data, q, v)
    if bias is None:
        bias = pin.nle(model, data, q, v)
    Minv = pin.computeMinverse(model, data, q)
    J, gamma = stack(model, data, constraints, v, baumgarte)
    return solve_kkt(Minv, tau - bias, J, gamma)


def stack(model, data, constraints, v, baumgarte: Baumgarte):
    """J and gamma = -(J'v + 2 alpha J v + beta^2 e) of the constraints, stacked."""
    if not constraints:
        return np.zeros((0, model.nv)), np.zeros(0)
    J = np.vstack([c.jacobian(model, data) for c in constraints])
    gamma = -np.concatenate([c.drift(model, data) for c in constraints])
    if baumgarte.active:
        gamma -= 2.0 * baumgarte.alpha * (J @ v)
        if baumgarte.beta:
            e = np.concatenate([c.residual(model, data) for c in constraints])
            gamma -= baumgarte.beta**2 * e
    return J, gamma
