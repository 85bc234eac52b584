"""Centre-of-mass trajectory by preview control of the cart-table model (Kajita et al. 2003).

The cart-table (linear inverted pendulum) model with the CoM at constant height z_c: state
x = (c, c', c''), input the jerk u, ZMP p = c - (z_c / g) c''. The optimal preview controller
with integral action (Katayama et al. 1985) minimises sum Q_e (p - p_ref)^2 + R u^2 given the
ZMP reference over a preview horizon; its gains come from the discrete algebraic Riccati
equation (``scipy.linalg.solve_discrete_are``).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

__all__ = ["PreviewController", "com_trajectory"]


@dataclass
class PreviewController:
    """Gains of the preview controller for one axis.

    Args:
        dt: Sample time [s]. z_c: CoM height [m]. g: Gravity [m/s^2].
        horizon: Preview time [s]. q_e, r: Weights of the ZMP error and of the jerk.
    """

    dt: float
    z_c: float
    g: float = 9.81
    horizon: float = 1.6
    q_e: float = 1.0
    r: float = 1e-6

    def __post_init__(self) -> None:
        from scipy.linalg import solve_discrete_are

        dt = self.dt
        self.A = np.array([[1.0, dt, dt**2 / 2], [0.0, 1.0, dt], [0.0, 0.0, 1.0]])
        self.B = np.array([[dt**3 / 6], [dt**2 / 2], [dt]])
        self.C = np.array([[1.0, 0.0, -self.z_c / self.g]])
        At = np.block([[np.eye(1), self.C @ self.A], [np.zeros((3, 1)), self.A]])
        Bt = np.vstack([self.C @ self.B, self.B])
        Q = np.diag([self.q_e, 0.0, 0.0, 0.0])
        R = np.array([[self.r]])
        P = solve_discrete_are(At, Bt, Q, R)
        S = np.linalg.inv(R + Bt.T @ P @ Bt)
        K = S @ Bt.T @ P @ At
        self.Gi, self.Gx = K[0, 0], K[0, 1:]
        n = int(round(self.horizon / dt))
        Ac = At - Bt @ K
        X = -Ac.T @ P @ np.array([[1.0], [0.0], [0.0], [0.0]])
        gd = np.zeros(n)
        gd[0] = -self.Gi
        for j in range(1, n):
            gd[j] = (S @ Bt.T @ X)[0, 0]
            X = Ac.T @ X
        self.Gd = gd

    def run(self, zmp_ref: np.ndarray, x0=(0.0, 0.0, 0.0)) -> np.ndarray:
        """CoM states (c, c', c'') for a ZMP reference sampled at dt (held after its end)."""
        n = len(zmp_ref)
        pad = np.concatenate([zmp_ref, np.full(len(self.Gd), zmp_ref[-1])])
        x = np.array(x0, dtype=float)
        out = np.zeros((n, 3))
        err = 0.0
        for k in range(n):
            out[k] = x
            p = (self.C @ x)[0]
            err += p - zmp_ref[k]
            u = -self.Gi * err - self.Gx @ x - self.Gd @ pad[k + 1 : k + 1 + len(self.Gd)]
            x = self.A @ x + self.B[:, 0] * u
        return out


def com_trajectory(plan, z_c: float, c0, dt: float = 5e-3, g: float = 9.81):
    """Horizontal CoM position, velocity and acceleration over a plan, sampled every dt.

    Returns:
        ``(t, c, dc, ddc)`` with c, dc, ddc of shape (N, 2) [m, m/s, m/s^2], and the ZMP of
        the cart-table model, shape (N, 2).
    """
    t = np.arange(0.0, plan.duration + dt / 2, dt)
    ref = np.array([plan.zmp(ti) for ti in t])
    ctl = PreviewController(dt, z_c, g)
    states = [ctl.run(ref[:, i], (c0[i], 0.0, 0.0)) for i in range(2)]
    c = np.stack([s[:, 0] for s in states], axis=1)
    dc = np.stack([s[:, 1] for s in states], axis=1)
    ddc = np.stack([s[:, 2] for s in states], axis=1)
    zmp = c - z_c / g * ddc
    return t, c, dc, ddc, zmp, ref
