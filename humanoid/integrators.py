"""Time integrators for (q, v) on the configuration Lie group, or on plain coordinates.

Every scheme advances ``dv/dt = f(t, q, v)`` together with ``dq/dt = v`` where "q + dt v" means
``space.integrate(q, dt v)``: Pinocchio's ``integrate`` (the exponential map of SE(3) and SO(3)
for free-flyer and ball joints) on the Lie group, or vector addition for the seeds' coordinate
formulation of quaternions.

Higher-order schemes use the Runge-Kutta-Munthe-Kaas form: every stage is expressed as a tangent
increment d at the step's start q0, and a stage velocity w (a tangent vector at q0 + d) becomes
the increment's rate through the inverse right Jacobian, d' = dexp_d^-1 w. This keeps the
classical order on the group (the naive scheme that adds stage velocities is second order only).

Schemes: explicit Euler (order 1), semi-implicit / symplectic Euler (order 1, bounded energy
error), classical RK4 (order 4), and an adaptive Dormand-Prince 5(4) pair with error control
(``rtol``, ``atol``), step rejection and statistics.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field

import numpy as np
import pinocchio as pin

__all__ = [
    "STEPPERS",
    "AdaptiveStats",
    "CoordinateSpace",
    "DormandPrince",
    "LieGroupSpace",
    "explicit_euler",
    "rk4",
    "semi_implicit_euler",
]

Dynamics = Callable[[float, np.ndarray, np.ndarray], np.ndarray]


class LieGroupSpace:
    """Configurations on Pinocchio's Lie group: q in R^nq, tangent vectors in R^nv."""

    def __init__(self, model: pin.Model) -> None:
        self.model = model
        self.nq, self.nv = model.nq, model.nv
        self._neutral = pin.neutral(model)

    def integrate(self, q: np.ndarray, d: np.ndarray) -> np.ndarray:
        return pin.integrate(self.model, q, d)

    def dexp_inv(self, d: np.ndarray, w: np.ndarray, q=None, qd=None) -> np.ndarray:
        """The rate of the increment d whose end point moves with tangent velocity w:
        Jr(d)^-1 w, the inverse right Jacobian of the exponential, joint by joint, in one C++
        call: Pinocchio's dDifference(q, qd) with qd = q (+) d is Jlog(exp(d)) = Jr(d)^-1 for
        every joint (block diagonal, the same at any base point q; the neutral configuration
        when the caller has none)."""
        if q is None or qd is None:
            q = self._neutral
            qd = pin.integrate(self.model, q, d)
        return pin.dDifference(self.model, q, qd, pin.ARG1) @ w


class CoordinateSpace:
    """Plain coordinates: q + d is vector addition (the seeds' quaternion formulation)."""

    def __init__(self, n: int) -> None:
        self.nq = self.nv = n

    def integrate(self, q: np.ndarray, d: np.ndarray) -> np.ndarray:
        return q + d

    def dexp_inv(self, d: np.ndarray, w: np.ndarray, q=None, qd=None) -> np.ndarray:
        return w


def explicit_euler(space, f: Dynamics, t: float, q, v, dt: float):
    """q+ = q (+) dt v,  v+ = v + dt f(t, q, v). Order 1."""
    a = f(t, q, v)
    return space.integrate(q, dt * v), v + dt * a


def semi_implicit_euler(space, f: Dynamics, t: float, q, v, dt: float):
    """v+ = v + dt f(t, q, v),  q+ = q (+) dt v+. Order 1, symplectic for separable systems."""
    v_new = v + dt * f(t, q, v)
    return space.integrate(q, dt * v_new), v_new


def _rk_stages(space, f, t, q, v, dt, A, c):
    """Stage increments (dq rates, dv rates) of an explicit RKMK tableau."""
    kq, kv = [], []
    for i, ci in enumerate(c):
        d = dt * sum(A[i][j] * kq[j] for j in range(i)) if i else np.zeros(space.nv)
        w = v + dt * sum(A[i][j] * kv[j] for j in range(i)) if i else v
        qs = space.integrate(q, d) if i else q
        kq.append(space.dexp_inv(d, w, q, qs) if i else w)
        kv.append(f(t + ci * dt, qs, w))
    return kq, kv


def rk4(space, f: Dynamics, t: float, q, v, dt: float):
    """Classical fourth-order Runge-Kutta (Munthe-Kaas form on the Lie group). Order 4.
    (Its tableau, c = (0, 1/2, 1/2, 1), b = (1, 2, 2, 1) / 6, written out rather than run
    through ``_rk_stages``: the same arithmetic in fewer Python steps.)"""
    h = 0.5 * dt
    kv1 = f(t, q, v)
    d, w = h * v, v + h * kv1
    q2 = space.integrate(q, d)
    kq2 = space.dexp_inv(d, w, q, q2)
    kv2 = f(t + h, q2, w)
    d, w = h * kq2, v + h * kv2
    q3 = space.integrate(q, d)
    kq3 = space.dexp_inv(d, w, q, q3)
    kv3 = f(t + h, q3, w)
    d, w = dt * kq3, v + dt * kv3
    q4 = space.integrate(q, d)
    kq4 = space.dexp_inv(d, w, q, q4)
    kv4 = f(t + dt, q4, w)
    sixth = dt / 6.0
    d = sixth * (v + 2.0 * (kq2 + kq3) + kq4)
    return space.integrate(q, d), v + sixth * (kv1 + 2.0 * (kv2 + kv3) + kv4)


# Dormand & Prince (1980) RK5(4)7M coefficients.
DP_C = (0.0, 1 / 5, 3 / 10, 4 / 5, 8 / 9, 1.0, 1.0)
DP_A = (
    (),
    (1 / 5,),
    (3 / 40, 9 / 40),
    (44 / 45, -56 / 15, 32 / 9),
    (19372 / 6561, -25360 / 2187, 64448 / 6561, -212 / 729),
    (9017 / 3168, -355 / 33, 46732 / 5247, 49 / 176, -5103 / 18656),
    (35 / 384, 0.0, 500 / 1113, 125 / 192, -2187 / 6784, 11 / 84),
)
DP_B5 = (35 / 384, 0.0, 500 / 1113, 125 / 192, -2187 / 6784, 11 / 84, 0.0)
DP_B4 = (5179 / 57600, 0.0, 7571 / 16695, 393 / 640, -92097 / 339200, 187 / 2100, 1 / 40)


@dataclass
class AdaptiveStats:
    """Counters of an adaptive run: accepted and rejected steps, dynamics evaluations."""

    accepted: int = 0
    rejected: int = 0
    evaluations: int = 0
    smallest_step: float = float("inf")
    largest_step: float = 0.0


@dataclass
class DormandPrince:
    """Adaptive Dormand-Prince 5(4) with error control, on the Lie group (RKMK).

    The error of a step is the RMS over all components of (x5 - x4) / (atol + rtol * s), with s
    the larger magnitude of the component at the step's start and end for velocities and 1 for
    position increments (positions are O(1) in metres and radians). A step is accepted when the
    error is <= 1; the next step size follows the usual controller h * 0.9 * err^(-1/5), clipped
    to [0.2, 5] times the current one.

    Attributes:
        rtol, atol: Relative and absolute tolerances.
        max_step: Largest step [s].
        min_step: Smallest step [s]; below it the run stops with an error.
        max_substeps: Most internal steps (accepted or rejected) in one call of
            :meth:`advance` (one tick of the scene); beyond it the run stops with an error (a
            spinning-up body can keep the step just above ``min_step`` for minutes).
        stats: Counters of the run.
    """

    rtol: float = 1e-6
    atol: float = 1e-8
    max_step: float = 0.05
    min_step: float = 1e-10
    max_substeps: int = 20000
    stats: AdaptiveStats = field(default_factory=AdaptiveStats)
    _h: float | None = None

    def advance(self, space, f: Dynamics, t: float, q, v, t_end: float):
        """Integrate from t to t_end with as many internal steps as the tolerances need."""
        from .errors import DivergenceError

        h = self._h or min(self.max_step, t_end - t, 1e-3)
        substeps = 0
        while t < t_end - 1e-15:
            substeps += 1
            if substeps > self.max_substeps:
                raise DivergenceError(
                    f"the adaptive integrator took {self.max_substeps} steps inside one tick "
                    f"at t = {t:.6f} s (step {h:.3g} s): the motion is too stiff or diverging"
                )
            h = min(h, t_end - t, self.max_step)
            kq, kv = _rk_stages(space, f, t, q, v, h, DP_A, DP_C)
            self.stats.evaluations += len(DP_C)
            d5 = h * sum(b * k for b, k in zip(DP_B5, kq, strict=True))
            v5 = v + h * sum(b * k for b, k in zip(DP_B5, kv, strict=True))
            d4 = h * sum(b * k for b, k in zip(DP_B4, kq, strict=True))
            v4 = v + h * sum(b * k for b, k in zip(DP_B4, kv, strict=True))
            scale_v = self.atol + self.rtol * np.maximum(np.abs(v), np.abs(v5))
            scale_q = self.atol + self.rtol
            err = np.sqrt(
                (np.sum(((d5 - d4) / scale_q) ** 2) + np.sum(((v5 - v4) / scale_v) ** 2))
                / (2 * len(v))
            )
            if not np.isfinite(err):
                err = np.inf
            if err <= 1.0:
                t += h
                q, v = space.integrate(q, d5), v5
                self.stats.accepted += 1
                self.stats.smallest_step = min(self.stats.smallest_step, h)
                self.stats.largest_step = max(self.stats.largest_step, h)
            else:
                self.stats.rejected += 1
            factor = 5.0 if err == 0 else min(5.0, max(0.2, 0.9 * err ** (-0.2)))
            h *= factor
            if h < self.min_step:
                raise DivergenceError(
                    f"adaptive step fell below {self.min_step:g} s at t = {t:.6f} s "
                    f"(error estimate {err:.3g}): the motion is too stiff or diverging"
                )
        self._h = h
        return q, v


# The fixed-step schemes by name (``humanoid.variants.INTEGRATORS`` lists them with
# "adaptive", the DormandPrince class).
STEPPERS = {
    "euler": explicit_euler,
    "semi_implicit_euler": semi_implicit_euler,
    "rk4": rk4,
}
