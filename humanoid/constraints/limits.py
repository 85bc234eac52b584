"""Joint ranges as unilateral rows, for hinges and for ball joints alike.

A hinge's range is its position limits. A ball joint (quaternion mode) keeps the anatomical
ranges of the hinge triplet it replaces: its rotation is decomposed into the triplet's Euler
angles (flexion, ab/adduction, axial rotation, in the triplet's order) and each angle keeps
its hinge's range, exactly as the Euler model would. A row is r(q) >= 0 (the distance inside
the range [rad]) with its Jacobian dr/dv: +-1 on a hinge; for a ball joint the row of E^-1,
E the map from the angle rates to the joint's angular velocity. Near the triplet's gimbal lock
(middle angle +-90 deg) the outer angles are undefined and their rows are left out there.
"""

from __future__ import annotations

import numpy as np
import pinocchio as pin

__all__ = ["JointRanges"]

MARGIN = 0.1  # [rad] rows closer than this to a limit are returned (speculative)
LOCK = 0.05  # |cos(middle angle)| below this: the outer angles of a ball are not defined


class JointRanges:
    """The joint ranges of a :class:`~humanoid.model.Humanoid` as unilateral rows."""

    def __init__(self, h) -> None:
        model = h.model
        self.nv = model.nv
        iq, iv, lo, hi = [], [], [], []
        ball_joints = {b.joint_id for b in h.fusion.balls} if h.fusion else set()
        for jm in model.joints[2:]:
            if jm.nq == 1 and jm.nv == 1 and jm.id not in ball_joints:
                a, b = model.lowerPositionLimit[jm.idx_q], model.upperPositionLimit[jm.idx_q]
                if np.isfinite(a) and np.isfinite(b) and a < b:
                    iq.append(jm.idx_q)
                    iv.append(jm.idx_v)
                    lo.append(a)
                    hi.append(b)
        self.iq, self.iv = np.array(iq, dtype=int), np.array(iv, dtype=int)
        self.lo, self.hi = np.array(lo), np.array(hi)
        self.balls = []  # (BallJoint, idx_q, idx_v, lower (3,), upper (3,))
        if h.fusion is not None:
            em = h.fusion.euler_model
            for b in h.fusion.balls:
                jm = model.joints[b.joint_id]
                qi = [em.joints[i].idx_q for i in b.hinge_ids]
                self.balls.append((b, jm.idx_q, jm.idx_v, em.lowerPositionLimit[qi].copy(),
                                   em.upperPositionLimit[qi].copy()))  # fmt: skip
        self._hints = [None] * len(self.balls)

    def angles(self, q) -> list[np.ndarray]:
        """Each ball joint's triplet angles [rad] (the branch inside the range, else the one
        nearest the previous call's)."""
        out = []
        for k, (b, iq, _, lo, hi) in enumerate(self.balls):
            R = pin.Quaternion(q[iq : iq + 4]).toRotationMatrix()
            a = b.angles(R, lo, hi, hint=self._hints[k])
            self._hints[k] = a
            out.append(a)
        return out

    def rows(self, q, margin: float | None = MARGIN):
        """Rows within ``margin`` [rad] of a limit (all rows if None): (r, J), r >= 0 inside."""
        margin = np.inf if margin is None else margin
        x = q[self.iq]
        r = np.concatenate([x - self.lo, self.hi - x])
        sign = np.concatenate([np.ones(len(x)), -np.ones(len(x))])
        cols = np.concatenate([self.iv, self.iv])
        keep = r < margin
        rs, Js = [r[keep]], []
        J = np.zeros((int(keep.sum()), self.nv))
        J[np.arange(len(J)), cols[keep]] = sign[keep]
        Js.append(J)
        for (b, _, iv, lo, hi), th in zip(self.balls, self.angles(q), strict=True):
            E = b.velocity_map(th)
            locked = abs(np.cos(th[1])) < LOCK
            rates = np.linalg.pinv(E) if locked else np.linalg.inv(E)  # angle rates per omega
            for i in range(3):
                if locked and i != 1:
                    continue
                for dist, s in ((th[i] - lo[i], 1.0), (hi[i] - th[i], -1.0)):
                    if dist < margin:
                        row = np.zeros(self.nv)
                        row[iv : iv + 3] = s * rates[i]
                        rs.append([dist])
                        Js.append(row[None])
        return np.concatenate(rs), np.vstack(Js)

    def violation(self, q) -> float:
        """Largest excursion beyond a range [rad] (0 inside every range)."""
        r, _ = self.rows(q, margin=0.0)
        return float(max(0.0, -r.min(initial=0.0)))
