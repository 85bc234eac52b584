"""Joint ranges as unilateral rows, for hinges and for ball joints alike.

A hinge's range is its position limits. A ball joint (quaternion mode) keeps the anatomical
ranges of the hinge triplet it replaces: its rotation is decomposed into the triplet's Euler
angles (flexion, ab/adduction, axial rotation, in the triplet's order) and each angle keeps
its hinge's range, exactly as the Euler model would. A row is r(q) >= 0 (the distance inside
the range [rad]) with its Jacobian dr/dv: +-1 on a hinge; for a ball joint the row of E^-1,
E the map from the angle rates to the joint's angular velocity. Near the triplet's gimbal lock
(middle angle +-90 deg) the outer angles are undefined and their rows are left out there.

All ball joints are decomposed at once (batched over the joints): this runs every step. Most
steps need no decomposition at all: after each one, every ball joint gets a certificate, the
largest rotation away from its current orientation that cannot bring any of its angles within
the margin of a limit (see :meth:`JointRanges.rows`), checked for all of them at once with one
``pin.difference`` from the configuration certified.
"""

from __future__ import annotations

import numpy as np
import pinocchio as pin

from .ground import KERNELS

__all__ = ["JointRanges", "range_violations"]

MARGIN = 0.1  # [rad] rows closer than this to a limit are returned (speculative)
LOCK = 0.05  # |cos(middle angle)| below this: the outer angles of a ball are not defined
VIOLATIONS_BLOCK = 1024  # states per block of range_violations


def _rotation_terms() -> np.ndarray:
    """The rotation matrix of a quaternion q (x, y, z, w) as a homogeneous quadratic form,
    R_ij = sum_kl T_ijkl q_k q_l (the rotation for unit q): T, (3, 3, 4, 4), so that a
    rotation's entries are one contraction with q q^T."""
    T = np.zeros((3, 3, 4, 4))
    x, y, z, w = range(4)
    for (i, j), terms in {
        (0, 0): ((w, w, 1), (x, x, 1), (y, y, -1), (z, z, -1)),
        (1, 1): ((w, w, 1), (x, x, -1), (y, y, 1), (z, z, -1)),
        (2, 2): ((w, w, 1), (x, x, -1), (y, y, -1), (z, z, 1)),
        (0, 1): ((x, y, 2), (z, w, -2)), (1, 0): ((x, y, 2), (z, w, 2)),
        (0, 2): ((x, z, 2), (y, w, 2)), (2, 0): ((x, z, 2), (y, w, -2)),
        (1, 2): ((y, z, 2), (x, w, -2)), (2, 1): ((y, z, 2), (x, w, 2)),
    }.items():  # fmt: skip
        for k, m, c in terms:
            T[i, j, k, m] += c
    return T


def _wrap(x):
    return (x + np.pi) % (2 * np.pi) - np.pi


def _wrap_in_place(x: np.ndarray) -> np.ndarray:
    """x = _wrap(x) in place, the same numbers for less: with x + pi within one turn of
    [0, 2 pi), its remainder is one subtraction of 2 pi (exact, as fmod) or, below 0, one
    addition (as NumPy's remainder and the kernel's wrap add it)."""
    x += np.pi
    if x.min(initial=0.0) >= -2 * np.pi and x.max(initial=0.0) < 4 * np.pi:
        np.subtract(x, 2 * np.pi, out=x, where=x >= 2 * np.pi)
        np.add(x, 2 * np.pi, out=x, where=x < 0.0)
    else:  # (NaN too)
        np.remainder(x, 2 * np.pi, out=x)
    x -= np.pi
    return x


def _kernel_plan(ranges: JointRanges):
    """The compiled kernel's copy of the ranges (humanoid/kernels.c: range_rows)."""
    assert KERNELS is not None
    i64, nb = np.int64, len(ranges.balls)
    ints = [np.ascontiguousarray(a, dtype=i64) for a in (ranges.iq, ranges.iv)]
    floats = [np.ascontiguousarray(a, dtype=float) for a in (ranges.lo, ranges.hi)]
    balls = [np.ascontiguousarray(ranges._bq.ravel(), dtype=i64),
             np.ascontiguousarray(ranges._bv, dtype=i64)]  # fmt: skip
    balls += [np.ascontiguousarray(a, dtype=float) for a in (ranges._blo, ranges._bhi,
              ranges._mid, ranges._W, ranges._s, ranges._GCt)]  # fmt: skip
    return KERNELS.range_plan(ranges.nv, len(ranges.iq), nb, LOCK, *ints, *floats, *balls)


class JointRanges:
    """The joint ranges of a :class:`~humanoid.model.Humanoid` as unilateral rows
    (``compiled=False``: :meth:`rows` on the NumPy path, with its certificates)."""

    def __init__(self, h, compiled: bool = True) -> None:
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
        self.hinge_ids = [j for j in range(2, model.njoints)
                          if model.joints[j].idx_q in set(self.iq.tolist())]  # fmt: skip
        self.lo, self.hi = np.array(lo), np.array(hi)
        self.balls = []  # (BallJoint, idx_q, idx_v, lower (3,), upper (3,))
        if h.fusion is not None:
            em = h.fusion.euler_model
            for b in h.fusion.balls:
                jm = model.joints[b.joint_id]
                qi = [em.joints[i].idx_q for i in b.hinge_ids]
                self.balls.append((b, jm.idx_q, jm.idx_v, em.lowerPositionLimit[qi].copy(),
                                   em.upperPositionLimit[qi].copy()))  # fmt: skip
        nb = len(self.balls)
        self._bq = np.array([iq for _, iq, *_ in self.balls], dtype=int).reshape(nb, 1)
        self._bv = np.array([iv for _, _, iv, *_ in self.balls], dtype=int)
        self._blo = np.array([lo for *_, lo, _ in self.balls]).reshape(nb, 3)
        self._bhi = np.array([hi for *_, hi in self.balls]).reshape(nb, 3)
        self._C = np.array([b.axes for b, *_ in self.balls]).reshape(nb, 3, 3)
        self._G = np.array([b.G for b, *_ in self.balls]).reshape(nb, 3, 3)
        self._s = np.sign(np.linalg.det(self._C)) if nb else np.zeros(0)
        self._GC = self._G.transpose(0, 2, 1) @ self._C
        self._GCt = self._GC.transpose(0, 2, 1).copy()
        self._mid = 0.5 * (self._blo + self._bhi)
        # the five entries of Wp = K^T R K (K = G^T C) that the Euler angles read, as quadratic
        # forms of each ball's quaternion: Wp[e] = W[b, e] . vec(q q^T)
        Wq = np.einsum("bik,ijmn,bjl->bklmn", self._GC, _rotation_terms(), self._GC)
        self._W = np.stack([Wq[:, 0, 2], Wq[:, 1, 2], Wq[:, 2, 2], Wq[:, 0, 1], Wq[:, 0, 0]],
                           axis=1).reshape(nb, 5, 16)  # fmt: skip
        self._bq4 = self._bq + np.arange(4)
        self._flip = np.array([[1.0, 1.0, 1.0], [1.0, -1.0, 1.0]])
        self._shift = np.array([[0.0, 0.0, 0.0], [np.pi, np.pi, np.pi]])
        self._mid2 = self._mid[:, None, :]
        self._lo2, self._hi2 = (self._blo - 1e-12)[:, None, :], (self._bhi + 1e-12)[:, None, :]
        self._prefer = np.tile([0.0, 1.0], (nb, 1))  # without a hint: the first solution
        self._balls_range = np.arange(nb)
        self._hint: np.ndarray | None = None
        self._bv3 = (self._bv[:, None] + np.arange(3)).ravel()
        nh = len(self.iq)
        self._hq = np.concatenate([self.iq, self.iq])
        self._hbound = np.concatenate([self.lo, self.hi])
        self._hsign = np.concatenate([np.ones(nh), -np.ones(nh)])
        self._hJ = np.zeros((2 * nh, self.nv))  # the hinge rows' Jacobian: +-1 on their v
        self._hJ[np.arange(2 * nh), np.concatenate([self.iv, self.iv])] = self._hsign
        self.model = model
        # (margin, the certified q, upper and lower bounds on q (-) q_c per velocity coordinate)
        self._certificate: tuple[float, np.ndarray, np.ndarray, np.ndarray] | None = None
        self.skipped = False  # whether the last call to rows skipped the decomposition
        self._no_rows = (np.zeros(0), np.zeros((0, self.nv)))  # (read-only: shared)
        for a in self._no_rows:
            a.flags.writeable = False
        # the compiled kernel's copy of the ranges (humanoid/kernels.c), or None
        self._plan = _kernel_plan(self) if compiled and KERNELS is not None else None
        self.max_rows = rows = 2 * nh + 6 * nb  # every bound of every hinge and ball angle
        self._out = (np.empty(rows), np.empty((rows, self.nv)), np.empty(rows, dtype=np.int64))
        self.ids: np.ndarray | None = None  # the compiled rows' bounds (< max_rows), or None
        self._angles_now = np.zeros((nb, 3))  # the compiled path's angles: its next hint

    def angles(self, q, remember: bool = True) -> np.ndarray:
        """Each ball joint's triplet angles [rad], (n_balls, 3).

        A rotation has two Euler-angle solutions (middle angle b or pi - b): the one inside
        the range; when both are (or neither), the one nearer the previous call's angles, else
        the one with |middle angle| <= pi/2 (as :meth:`BallJoint.angles`).
        """
        return self._angles(q, remember)

    def _angles(self, q, remember: bool = True):
        quats = q[self._bq4]
        w = (self._W @ (quats[:, :, None] * quats[:, None, :]).reshape(len(quats), 16, 1))[
            :, :, 0
        ]  # w02, w12, w22, w01, w00 of Wp = K^T R K = Rx(s t1) Ry(s t2) Rz(s t3)
        abc = np.stack([np.arctan2(-w[:, 1], w[:, 2]), np.arcsin(np.clip(w[:, 0], -1.0, 1.0)),
                        np.arctan2(-w[:, 3], w[:, 4])], axis=1)  # fmt: skip
        # the two solutions, (a, b, c) and (a + pi, pi - b, c + pi) times s (as
        # fusion.euler_solutions), each angle within +-pi of its range's centre (so that a
        # range reaching +-180 deg, the shoulder's flexion, is continuous across it)
        both = self._s[:, None, None] * (abc[:, None, :] * self._flip + self._shift)
        both = self._mid2 + _wrap(both - self._mid2)
        inside = ((both >= self._lo2) & (both <= self._hi2)).all(axis=2)
        if self._hint is None:
            d = self._prefer
        else:
            d = np.abs(_wrap(both - self._hint[:, None, :])).sum(axis=2)
        in1, in2 = inside[:, 0], inside[:, 1]
        pick = (in2 & ~in1) | ((in1 == in2) & (d[:, 1] < d[:, 0]))
        th = both[self._balls_range, pick.astype(int)]
        if remember:
            self._hint = th
        return th

    def _clear(self, q, margin: float) -> np.ndarray | None:
        """Which coordinates of q are certified clear of their limits by the margin (a bool
        per velocity coordinate), or None without a certificate for this margin.

        d = q (-) q_c, the difference from the certified configuration (one C++ call): a
        hinge's d is its exact displacement, checked against its distances to its limits; a
        ball's d is its rotation vector from there, inside the box of half-width phi / sqrt(3)
        (so |d| <= phi, :meth:`_certify`)."""
        c = self._certificate
        if c is None or c[0] != margin:
            return None
        d = pin.difference(self.model, c[1], q)
        return (d <= c[2]) & (d >= c[3])

    def _certify(self, q, th, margin: float) -> None:
        """Certificates at q: every hinge's distances to its limits beyond the margin, and
        every ball's largest rotation phi away from its orientation now that keeps each of its
        angles (th) more than ``margin`` inside its range.

        With R = Rx(t1) Ry(t2) Rz(t3) and w the angular velocity, the angle rates are
        t1' = (w_x cos t3 - w_y sin t3) / cos t2, t2' = w_x sin t3 + w_y cos t3,
        t3' = w_z - tan t2 (w_x cos t3 - w_y sin t3): each at most (1 + 1/cos t2) |w|. Along
        the geodesic to any orientation within phi (|w| = phi per unit path), |t2| grows by at
        most phi, so every angle moves by at most phi (1 + 1/cos(|t2| + phi)). With s the
        slack (the smallest distance to a limit beyond the margin), capped at half the way to
        the lock, phi = s / (1 + 1/cos(|t2| + s)) keeps that bound below s."""
        up, down = np.full(self.nv, np.inf), np.full(self.nv, -np.inf)
        x = q[self.iq]
        up[self.iv], down[self.iv] = self.hi - margin - x, self.lo + margin - x
        if self.balls:
            slack = np.minimum(th - self._blo, self._bhi - th).min(axis=1) - margin
            b = np.abs(th[:, 1])
            s = np.minimum(slack, 0.5 * (np.pi / 2 - b))
            with np.errstate(divide="ignore", invalid="ignore"):  # only where s <= 0, unused
                phi = np.where(s > 0, s / (1.0 + 1.0 / np.cos(b + np.maximum(s, 0.0))), -1.0)
            box = np.repeat(phi / np.sqrt(3.0), 3)  # a negative box: never clear
            up[self._bv3], down[self._bv3] = box, -box
        self._certificate = (margin, q.copy(), up, down)

    def rows(self, q, margin: float | None = MARGIN, certified: bool = True):
        """Rows within ``margin`` [rad] of a limit (all rows if None): (r, J), r >= 0 inside.
        ``certified``: skip the ball joints' decomposition when the last one's certificates
        show that none of their rows can be within the margin (the same answer, tested; False
        decomposes every time). ``skipped`` then tells whether this call skipped it.
        """
        margin = np.inf if margin is None else margin
        if certified and self._plan is not None:
            return _compiled_rows(self, q, margin)
        self.ids = None
        clear = self._clear(q, margin) if certified and np.isfinite(margin) else None
        if clear is not None and clear.all():
            self.skipped = True
            return self._no_rows
        self.skipped = clear is not None and bool(clear[self._bv3].all())
        r, J = self.hinge_rows(q)
        keep = r < margin
        J = J[keep]
        if self.skipped:
            return r[keep], J
        th = self._angles(q) if self.balls else None
        if np.isfinite(margin):
            self._certify(q, th, margin)
        if not self.balls:
            return r[keep], J
        assert th is not None  # the angles were read above: there are balls
        dist = np.stack([th - self._blo, self._bhi - th], axis=2)  # (n_balls, angle, lo/hi)
        locked = np.abs(np.cos(th[:, 1])) < LOCK
        near = dist < margin
        near[locked, 0] = near[locked, 2] = False  # the outer angles are undefined at the lock
        if not near.any():
            return r[keep], J
        # the angle rates from the joint's angular velocity w (its v): with K = G^T C the
        # triplet's axes in the joint's frame, Wp = K^T R K = Rx(a) Ry(b) Rz(c), (a, b, c) =
        # s th, turns at w_W = s K^T w, and a' = (w_x cos c - w_y sin c) / cos b,
        # b' = w_x sin c + w_y cos c, c' = w_z - tan b (w_x cos c - w_y sin c): th' = E^-1 K^T w
        # (the outer rows are undefined at the lock, where they are left out)
        b_, c_ = self._s * th[:, 1], self._s * th[:, 2]
        cb = np.where(locked, 1.0, np.cos(b_))
        cc, sc, tb = np.cos(c_), np.sin(c_), np.sin(b_) / cb
        Einv = np.zeros((len(th), 3, 3))
        Einv[:, 0, 0], Einv[:, 0, 1] = cc / cb, -sc / cb
        Einv[:, 1, 0], Einv[:, 1, 1] = sc, cc
        Einv[:, 2, 0], Einv[:, 2, 1], Einv[:, 2, 2] = -tb * cc, tb * sc, 1.0
        rates = Einv @ self._GCt
        b, i, side = np.nonzero(near)
        Jb = np.zeros((len(b), self.nv))
        sgn = np.where(side == 0, 1.0, -1.0)[:, None]
        Jb[np.arange(len(b))[:, None], self._bv[b][:, None] + np.arange(3)] = sgn * rates[b, i]
        return np.concatenate([r[keep], dist[b, i, side]]), np.vstack([J, Jb])

    def hinge_rows(self, q):
        """Every hinge's two rows (lower, then upper bound): (r, J), r >= 0 inside, J constant
        (+-1 on the hinge's velocity)."""
        return self._hsign * (q[self._hq] - self._hbound), self._hJ

    def names(self) -> list[str]:
        """A name per entry of :meth:`excess`'s halves: each hinge's joint, then each ball
        joint's three hinges (the triplet it replaces)."""
        out = [self.model.names[j] for j in self.hinge_ids]
        for b, *_ in self.balls:
            out += list(b.hinges)
        return out

    def clamp(self, q) -> tuple[np.ndarray, np.ndarray]:
        """``q`` with every hinge and every ball joint's angle inside its range, and how far each
        was past it [rad] (>= 0, in :meth:`names`'s order): a ball's angles clipped and its
        rotation made again from them."""
        out = np.array(q, dtype=float, copy=True)
        x = out[self.iq]
        past = [np.maximum(self.lo - x, 0.0) + np.maximum(x - self.hi, 0.0)]
        out[self.iq] = np.clip(x, self.lo, self.hi)
        if self.balls:
            th = self.angles(out, remember=False)
            past.append((np.maximum(self._blo - th, 0.0) + np.maximum(th - self._bhi, 0.0)).ravel())
            for (b, iq, *_), a, lo, hi in zip(self.balls, th, self._blo, self._bhi, strict=True):
                if np.any(a < lo) or np.any(a > hi):
                    out[iq : iq + 4] = pin.Quaternion(b.rotation(np.clip(a, lo, hi))).coeffs()
        return out, np.concatenate(past)

    def excess(self, q) -> np.ndarray:
        """How far q is beyond each bound [rad], >= 0 (0 inside): every hinge's lower and upper
        bound, then every ball joint's three angles' (a vector of fixed length)."""
        x = q[self.iq]
        out = [self.lo - x, x - self.hi]
        if self.balls:
            th = self.angles(q, remember=False)
            out += [(self._blo - th).ravel(), (th - self._bhi).ravel()]
        return np.maximum(np.concatenate(out), 0.0)

    def violation(self, q) -> float:
        """Largest excursion beyond a range [rad] (0 inside every range)."""
        r, _ = self.rows(q, margin=0.0)
        return float(max(0.0, -r.min(initial=0.0)))


def _compiled_rows(ranges: JointRanges, q, margin: float):
    """:meth:`JointRanges.rows` in C: every ball decomposed (cheaper than a certificate's
    check), the last call's angles the hint."""
    assert KERNELS is not None
    (r, J, ids), hint = ranges._out, ranges._hint is not None
    if hint and ranges._hint is not ranges._angles_now:
        ranges._angles_now[:] = ranges._hint
    m = KERNELS.range_rows(ranges._plan, np.ascontiguousarray(q, dtype=float), margin,
                           ranges._angles_now, hint, r, J, ids)  # fmt: skip
    ranges._hint, ranges.skipped, ranges.ids = ranges._angles_now, False, ids[:m].copy()
    return r[:m].copy(), J[:m].copy()


def range_violations(ranges: JointRanges, Q) -> np.ndarray:
    """:meth:`JointRanges.violation` at each configuration of Q (n, nq) [rad], the same numbers
    as calling it on them in order, for a fraction of the cost.

    On the compiled path every call decomposes every ball, the last call's angles the hint of
    its branch (:meth:`JointRanges.angles`): here a block of states at a time in NumPy, the
    hint chained from state to state (:func:`_chained_angles`), the last state's angles left
    as the next call's hint (``ids``, the rows of a call, is left None). The NumPy path's
    certificates skip states (its hints follow them): there, state by state."""
    Q = np.asarray(Q, dtype=float).reshape(-1, ranges.model.nq)
    if ranges._plan is None:
        return np.array([ranges.violation(q) for q in Q])
    # blocks: small arrays (in the cache, no fresh pages); the hint carries over
    blocks = range(0, len(Q), VIOLATIONS_BLOCK)
    return np.concatenate([np.zeros(0)] + [_violations(ranges, Q[a : a + VIOLATIONS_BLOCK])
                                           for a in blocks])  # fmt: skip


def _violations(ranges: JointRanges, Q) -> np.ndarray:
    """:func:`range_violations` of a block of states on the compiled path."""
    x = Q[:, ranges.iq].T
    # the rows' r < 0 as excursions: -(x - lo) and x - hi, the angles' alike (the outer ones
    # left out at the lock); NaN rows are skipped, as the kernel skips them
    past = [ranges.lo[:, None] - x, x - ranges.hi[:, None]]
    if ranges.balls:
        th = _chained_angles(ranges, Q)  # (n_balls, angle, state)
        out = np.fmax(ranges._blo[:, :, None] - th, th - ranges._bhi[:, :, None])
        locked = np.abs(np.cos(th[:, 1])) < LOCK
        out[:, 0][locked] = out[:, 2][locked] = np.nan
        past.append(out.reshape(-1, len(Q)))
        ranges._angles_now[:] = th[:, :, -1]
        ranges._hint, ranges.skipped, ranges.ids = ranges._angles_now, False, None
    return np.fmax.reduce(np.concatenate(past), axis=0, initial=0.0)


def _chained_angles(ranges: JointRanges, Q) -> np.ndarray:
    """Each ball's triplet angles at each configuration (n_balls, 3, n), as the compiled
    :meth:`JointRanges.rows` picks them called on Q in order: the solution inside the range,
    and where both or neither are, the one nearer the previous state's angles (the first
    state's: the last call's, if any, else the first solution). Only those ambiguous states
    are resolved one by one (none in a walk within its ranges). The states are the last axis
    (NumPy's loops run along it)."""
    n, nb = len(Q), len(ranges.balls)
    quats = np.ascontiguousarray(Q[:, ranges._bq4.ravel()].T).reshape(nb, 4, n)
    qq = (quats[:, :, None, :] * quats[:, None, :, :]).reshape(nb, 16, n)
    w = ranges._W @ qq  # (nb, 5, n): the entries of K^T R K the angles read
    abc = np.empty((nb, 1, 3, n))
    np.arctan2(-w[:, 1], w[:, 2], out=abc[:, 0, 0])
    np.arcsin(np.clip(w[:, 0], -1.0, 1.0), out=abc[:, 0, 1])
    np.arctan2(-w[:, 3], w[:, 4], out=abc[:, 0, 2])
    both = np.multiply(abc, ranges._flip[:, :, None])  # (nb, solution, angle, n)
    both += ranges._shift[:, :, None]
    both *= ranges._s[:, None, None, None]
    mid = ranges._mid2[..., None]
    both -= mid
    _wrap_in_place(both)
    both += mid
    inside = ((both >= ranges._lo2[..., None]) & (both <= ranges._hi2[..., None])).all(axis=2)
    pick = inside[:, 1] & ~inside[:, 0]
    b, k = np.nonzero(inside[:, 0] == inside[:, 1])  # by ball, then state
    if len(b):
        hint = np.where((k > 0)[:, None, None], both[b, :, :, np.maximum(k - 1, 0)], np.nan)
        if ranges._hint is not None:  # the first state's: the last call's angles
            hint[k == 0] = ranges._hint[b[k == 0]][:, None, :]
        # d[m, solution, the previous state's solution]: the distance the kernel compares
        d = np.abs(_wrap(both[b, :, :, k][:, :, None, :] - hint[:, None, :, :])).sum(axis=3)
        # the pick after the previous state's first or second solution (flat lists: cheap)
        after = [(d[:, 1, p] < d[:, 0, p]).tolist() for p in (0, 1)]
        flat, first = pick.ravel().tolist(), ranges._hint is not None
        for m, i in enumerate((b * n + k).tolist()):
            if i % n:
                flat[i] = after[flat[i - 1]][m]
            elif first:
                flat[i] = after[0][m]
        pick = np.array(flat, dtype=bool).reshape(nb, n)
    return np.where(pick[:, None, :], both[:, 1], both[:, 0])
