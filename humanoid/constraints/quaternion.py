"""The seeds' coordinate formulation of quaternions: |Q|^2 = 1 as a constraint.

In Pinocchio's Lie-group formulation a ball or free joint has a unit quaternion in q and an
angular velocity in v, and ``pin.integrate`` keeps |Q| = 1 by construction. The seeds instead
take the quaternion components themselves and their time derivatives as the state, x = q and
x' = q', and add |Q|^2 = 1 as a constraint with its own multiplier. This module provides that
formulation so that the two can be compared:

- the velocity map v = H(x) x' (per quaternion, the body angular velocity
  omega = 2 [w I - [u]x, -u] Q' for Q = (u, w) in Pinocchio's (x, y, z, w) order; per free
  flyer, the body-frame linear velocity R^T p');
- the mass matrix M_x = H^T M H (singular along each Q: the radial direction carries no
  kinetic energy) and the generalised forces H^T (tau - b - M H' x');
- one :class:`QuaternionNorm` row per quaternion: e = |Q|^2 - 1, J = 2 Q^T, drift 2 |Q'|^2.

The KKT system of this formulation is assembled densely (M_x is singular, so there is no
M^-1): it is an ablation to measure, not the fast path.
"""

from __future__ import annotations

import numpy as np
import pinocchio as pin

from ..errors import SceneError

__all__ = ["CoordinateMap", "QuaternionNorm"]


class CoordinateMap:
    """Maps between Pinocchio's (q, v) and the coordinate state (x, x'), both of size nq."""

    def __init__(self, model: pin.Model) -> None:
        self.model = model
        self.nq, self.nv = model.nq, model.nv
        self.quats = []  # (q index of the quaternion, v index of the angular velocity)
        self.free = []  # (q index of the position, v index of the linear velocity, quat q index)
        self.scalars = []  # (q index, v index) of 1-DoF joints
        for jm in model.joints[1:]:
            name = jm.shortname()
            if name == "JointModelFreeFlyer":
                self.free.append((jm.idx_q, jm.idx_v, jm.idx_q + 3))
                self.quats.append((jm.idx_q + 3, jm.idx_v + 3))
            elif name == "JointModelSpherical":
                self.quats.append((jm.idx_q, jm.idx_v))
            elif jm.nq == 1 and jm.nv == 1:
                self.scalars.append((jm.idx_q, jm.idx_v))
            else:
                raise SceneError(
                    f"stabilisation.quaternions = 'coordinates' handles free-flyer, ball and "
                    f"1-DoF joints; joint {model.names[jm.id]!r} is a {name}: use 'lie'"
                )
        self.quat_rows = np.array([iq for iq, _ in self.quats], dtype=int)

    def configuration(self, x: np.ndarray) -> np.ndarray:
        """Pinocchio configuration of x: the quaternions normalised (kinematics need |Q| = 1)."""
        q = x.copy()
        for iq, _ in self.quats:
            q[iq : iq + 4] /= np.linalg.norm(q[iq : iq + 4])
        return q

    def H(self, x: np.ndarray) -> np.ndarray:
        """The (nv x nq) matrix with v = H(x) x'."""
        H = np.zeros((self.nv, self.nq))
        for iq, iv in self.scalars:
            H[iv, iq] = 1.0
        for iq, iv in self.quats:
            u, w = x[iq : iq + 3], x[iq + 3]
            H[iv : iv + 3, iq : iq + 3] = 2.0 * (w * np.eye(3) - pin.skew(u))
            H[iv : iv + 3, iq + 3] = -2.0 * u
        for ip, iv, iquat in self.free:
            R = pin.Quaternion(self.configuration(x)[iquat : iquat + 4]).toRotationMatrix()
            H[iv : iv + 3, ip : ip + 3] = R.T
        return H

    def Hdot_xdot(self, x: np.ndarray, xdot: np.ndarray) -> np.ndarray:
        """H'(x, x') x' (only the free flyer's translation contributes: -omega x v_lin)."""
        out = np.zeros(self.nv)
        v = self.H(x) @ xdot
        for _, iv, _ in self.free:
            out[iv : iv + 3] = -np.cross(v[iv + 3 : iv + 6], v[iv : iv + 3])
        return out

    def from_tangent(self, q: np.ndarray, v: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """(x, x') of a Pinocchio state: x = q, x' the derivative of q along v."""
        x = q.copy()
        xdot = np.zeros(self.nq)
        for iq, iv in self.scalars:
            xdot[iq] = v[iv]
        for iq, iv in self.quats:
            Q = pin.Quaternion(q[iq : iq + 4])
            dQ = Q * pin.Quaternion(0.0, *(0.5 * v[iv : iv + 3]))
            xdot[iq : iq + 4] = dQ.coeffs()
        for ip, iv, iquat in self.free:
            R = pin.Quaternion(q[iquat : iquat + 4]).toRotationMatrix()
            xdot[ip : ip + 3] = R @ v[iv : iv + 3]
        return x, xdot


class QuaternionNorm:
    """|Q|^2 - 1 = 0 for every quaternion of the coordinate state (one row each)."""

    def __init__(self, cmap: CoordinateMap) -> None:
        self.cmap = cmap
        self.size = len(cmap.quats)
        self.name = "quaternion_norm"

    def residual(self, x: np.ndarray) -> np.ndarray:
        return np.array([x[iq : iq + 4] @ x[iq : iq + 4] - 1.0 for iq, _ in self.cmap.quats])

    def jacobian(self, x: np.ndarray) -> np.ndarray:
        J = np.zeros((self.size, self.cmap.nq))
        for row, (iq, _) in enumerate(self.cmap.quats):
            J[row, iq : iq + 4] = 2.0 * x[iq : iq + 4]
        return J

    def drift(self, xdot: np.ndarray) -> np.ndarray:
        return np.array([2.0 * xdot[iq : iq + 4] @ xdot[iq : iq + 4] for iq, _ in self.cmap.quats])
