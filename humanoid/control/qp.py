"""The one whole-body QP of the toolkit's controllers (the welded walk, the person's walk, the
human gait and motion tracking): over x = (dv, f / weight), the generalised acceleration and the
loaded contact points' forces in body weights,

- costs: the tasks on dv (:mod:`humanoid.control.tasks`) and the force tasks on f;
- equalities: the free flyer's six rows of the dynamics (never actuated), and the contacts'
  motion rows (points brought to rest on the ground, or the plant's welds);
- inequalities: a friction pyramid per loaded point, each point's normal force under its
  upper bound (a bound that ramps to zero unloads a point before it lifts), the free points
  kept off the floor, the joint ranges as velocity dampers.

Solved by ProxQP (proxsuite's dense solver), kept between ticks and warm-started."""

from __future__ import annotations

import functools
from dataclasses import dataclass
from typing import Any

import numpy as np
import pinocchio as pin

from ..errors import RunFailed
from ..linalg import cross
from .tasks import ForceTask

__all__ = [
    "ContactQP",
    "JointWrenches",
    "WarmQP",
    "checked",
    "contact_qp",
    "dynamics_terms",
    "feet_contacts",
    "frame_jacobians",
    "point_drifts",
    "pyramid_rows",
    "ramped_bound",
    "range_damper",
    "row_space",
    "whole_body_qp",
]

# ProxQP's default inner cap (1500) let one infeasible tick of a Talos walk take 1.4 million
# iterations (11 s) before the controller could fall back; a walk's solves take at most 62 in all
MAX_INNER = 100


class WarmQP:
    """ProxQP (dense), kept between ticks while the problem's dimensions stay the same and
    warm-started from the last solution; minimises 1/2 x'Px + q'x subject to A x = b and
    G x <= h.

    Its infeasibility detection is switched off: a walking QP is always feasible (zero forces
    and a falling base satisfy every constraint), and ProxQP's default test declared false
    infeasibility on near-degenerate single-support problems.

    Args:
        eps_abs: ProxQP's absolute tolerance. max_iter: its iteration cap (outer; each outer
            iteration's inner ones are capped at ``MAX_INNER``).
        primal, dual: at the iteration cap, a point with residuals below these is accepted (the
            constraints are what the physics needs; the dual residual only measures the
            optimality of the weights).
    """

    def __init__(self, eps_abs: float, max_iter: int, primal: float, dual: float) -> None:
        self.eps_abs, self.max_iter, self.primal, self.dual = eps_abs, max_iter, primal, dual
        self._qp: Any = None  # proxsuite's dense QP, built at the first solve
        self._dims: tuple[int, int, int] | None = None
        self.iterations = 0
        self.why = ""  # why the last solve was refused

    def solve(self, P, q, A, b, G, h) -> np.ndarray | None:
        """The solution, or None when ProxQP neither solved nor reached an acceptable point."""
        import proxsuite

        dims = (P.shape[0], A.shape[0], G.shape[0])
        lower = np.full(len(h), -1e20)
        if self._dims != dims:
            qp = proxsuite.proxqp.dense.QP(*dims)
            qp.settings.eps_abs = self.eps_abs
            qp.settings.eps_rel = 0.0
            qp.settings.max_iter = self.max_iter
            qp.settings.max_iter_in = MAX_INNER
            qp.settings.eps_primal_inf = 1e-30
            qp.settings.eps_dual_inf = 1e-30
            guess = proxsuite.proxqp.InitialGuess.WARM_START_WITH_PREVIOUS_RESULT
            qp.settings.initial_guess = guess
            qp.init(P, q, A, b, G, lower, h)
            self._qp, self._dims = qp, dims
        else:
            self._qp.update(P, q, A, b, G, lower, h)
        qp = self._qp
        qp.solve()
        info = qp.results.info
        self.iterations = info.iter
        status = proxsuite.proxqp.QPSolverOutput
        usable = info.status == status.PROXQP_MAX_ITER_REACHED and (
            info.pri_res < self.primal and info.dua_res < self.dual
        )
        if info.status == status.PROXQP_SOLVED or usable:
            return qp.results.x.copy()
        self.why = f"{info.status}: primal {info.pri_res:.1e}, dual {info.dua_res:.1e}"
        return None


def checked(x, what: str, t: float, solver: WarmQP) -> np.ndarray:
    """``x``, a controller's QP solution, or :class:`~humanoid.errors.RunFailed` naming the
    controller (``what``), the time [s] and why ProxQP refused (the run stops as failed and
    keeps what it computed)."""
    if x is None or not np.all(np.isfinite(x)):
        why = solver.why if x is None else "a solution that is not finite"
        raise RunFailed(f"the {what} QP has no solution at t = {t:.3f} s ({why})")
    return x


def pyramid_rows(mu: float, points: int, columns: int, offset: int) -> np.ndarray:
    """G rows (G x <= 0) keeping each point's force (x[offset + 3 i : offset + 3 i + 3], world
    axes, z up) in a friction pyramid inscribed in the cone of coefficient ``mu``:
    f_z >= 0 and |f_x|, |f_y| <= (mu / sqrt 2) f_z."""
    return _pyramids(float(mu), points, columns, offset).copy()


@functools.lru_cache(maxsize=64)
def _pyramids(mu: float, points: int, columns: int, offset: int) -> np.ndarray:
    """:func:`pyramid_rows`, built once per shape (a controller asks for the same few)."""
    m = mu / np.sqrt(2.0)
    pyramid = np.array([[0, 0, -1.0], [1, 0, -m], [-1, 0, -m], [0, 1, -m], [0, -1, -m]])
    G = np.zeros((5 * points, columns))
    if points:
        rows = 5 * np.arange(points)[:, None, None] + np.arange(5)[None, :, None]
        cols = offset + 3 * np.arange(points)[:, None, None] + np.arange(3)[None, None, :]
        G[rows, cols] = pyramid
    G.flags.writeable = False
    return G


def range_damper(ranges, q, v, period: float, margin: float, time: float):
    """The joint ranges as a velocity damper on the acceleration dv: every range row
    r(q) >= 0 within ``margin`` of its limit may close its gap no faster than r' >= -r / time
    after the control ``period`` dt, r' + dt r'' >= -r / time, so the gap shrinks
    geometrically and is never crossed. Returns (J, bound) with -J dv <= bound."""
    r, J = ranges.rows(q, margin=margin)
    return J, (J @ v + r / time) / period


def dynamics_terms(model, data, q, v) -> tuple[np.ndarray, np.ndarray]:
    """The kinematics a task-space QP reads (placements, velocities, drift accelerations,
    joint Jacobians, frames) brought to (q, v), and the mass matrix (symmetric) and the
    nonlinear effects h(q, v)."""
    nv = model.nv
    pin.forwardKinematics(model, data, q, v, np.zeros(nv))
    pin.computeJointJacobians(model, data, q)
    pin.updateFramePlacements(model, data)
    M = pin.crba(model, data, q)
    return M, pin.nle(model, data, q, v)  # (Pinocchio's binding fills both triangles)


def feet_contacts(solver, model, data, foot_joint: dict, q=None):
    """The plant's own ground detection (a :class:`~humanoid.constraints.ground.GroundContacts`;
    ``solver``: the plant's contact solver) and, per point, the side whose foot it is on (None:
    another body). ``foot_joint``: side -> the foot's joint, or a set of joints (a foot with
    free toes: its rearfoot's and its toes'). ``q``: the configuration of ``data``'s
    placements (the plant's step at the same state then finds these contacts without detecting
    them again)."""
    found = solver.ground.detect(model, data, at=q)
    joints = {s: {j} if isinstance(j, int) else set(j) for s, j in foot_joint.items()}
    side_of = [next((s for s, js in joints.items() if j in js), None)
               for j in found.joints.tolist()]  # fmt: skip
    return found, side_of


@dataclass
class ContactQP:
    """The whole-body QP: minimise 1/2 x'Px + q'x subject to A x = b, G x <= h, over
    x = (dv, f / weight). ``Jc``: the loaded points' Jacobian (3 rows each, world axes);
    ``U``: the independent combinations of its rows that the sticking equalities use (after
    the root's 6 rows of A); ``cones``: how many rows of G, first, keep the forces in their
    pyramids (then each point's upper bound, if any)."""

    P: np.ndarray
    q: np.ndarray
    A: np.ndarray
    b: np.ndarray
    G: np.ndarray
    h: np.ndarray
    Jc: np.ndarray
    U: np.ndarray
    cones: int

    def solve(self, solver: WarmQP, relax: bool = True):
        """(x, relaxed): the solution, and whether only the dynamics and the loaded points'
        pyramids held (``relax``: :meth:`solve_cones`, tried when the whole problem has no
        solution). x is None if neither solved."""
        x = solver.solve(self.P, self.q, self.A, self.b, self.G, self.h)
        if x is not None or not relax:
            return x, False
        return self.solve_cones(solver), True

    def solve_cones(self, solver: WarmQP):
        """The solution with only the equalities and the loaded points' pyramids (no force
        bounds, no floor rows for the free points, no range dampers: the plant enforces the
        last two itself), or None."""
        return solver.solve(self.P, self.q, self.A, self.b, self.G[: self.cones],
                            self.h[: self.cones])  # fmt: skip

    def torques(self, x: np.ndarray, M: np.ndarray, hvec: np.ndarray, weight: float):
        """(tau, dv, f): the joint torques of solution x (the free flyer's zero), its
        acceleration and the loaded points' forces [N] (k, 3)."""
        nv = M.shape[0]
        dv, f = x[:nv], weight * x[nv:]
        tau = M @ dv + hvec - self.Jc.T @ f
        tau[:6] = 0.0
        return tau, dv, f.reshape(-1, 3)


def whole_body_qp(M, hvec, weight: float, tasks, Jc, mu: float, *, forces=(), motion=(),
                  bounds=(), upper=None, ridge: float = 0.0, U=None) -> ContactQP:  # fmt: skip
    """The QP of the module docstring.

    Args:
        M, hvec: the mass matrix and the nonlinear effects at the state.
        weight: the body's weight [N] (forces are solved in body weights).
        tasks: the :class:`~humanoid.control.tasks.TaskStack` of the costs on dv.
        Jc: the loaded points' Jacobian (3k, nv), world axes.
        mu: the friction pyramids' coefficient (inscribed in the cone).
        forces: :class:`~humanoid.control.tasks.ForceTask` s on the k points' forces.
        motion: (A, b) equalities A dv = b (sticking rows, welds).
        bounds: (C, d) inequalities C dv <= d (free points, joint ranges).
        upper: the k points' normal-force upper bounds [body weights], or None.
        ridge: added to P's diagonal.
        U: see :class:`ContactQP` (kept for a caller's fallback).
    """
    nv = M.shape[0]
    nf = Jc.shape[0]
    n = nv + nf
    B, a, W = tasks.stacked()
    P = np.zeros((n, n))
    qv = np.zeros(n)
    P[:nv, :nv] = B.T @ (W[:, None] * B)
    qv[:nv] = -B.T @ (W * a)
    for task in forces:
        if task.rows is None:  # S = I: the weight on the forces' diagonal
            P.flat[nv * (n + 1) :: n + 1] += task.weight
            qv[nv:] -= task.weight * np.asarray(task.target, dtype=float)
            continue
        Pf, qf = task.terms(nf)
        P[nv:, nv:] += Pf
        qv[nv:] += qf
    if ridge:
        P.flat[:: n + 1] += ridge
    # the equalities and the inequalities written in place (the same numbers as stacking)
    motion = [(A, b) for A, b in motion]
    bounds = [(C, d) for C, d in bounds if len(C)]
    A_eq = np.zeros((6 + sum(len(A) for A, _ in motion), n))
    b_eq = np.empty(len(A_eq))
    A_eq[:6, :nv] = M[:6]
    A_eq[:6, nv:] = -weight * Jc.T[:6]
    b_eq[:6] = -hvec[:6]
    r = 6
    for A, b in motion:
        A_eq[r : r + len(A), :nv] = A
        b_eq[r : r + len(A)] = b
        r += len(A)
    k = nf // 3
    cones = 5 * k
    capped = upper is not None and k > 0
    G = np.zeros((cones + (k if capped else 0) + sum(len(C) for C, _ in bounds), n))
    h = np.zeros(len(G))
    G[:cones] = _pyramids(float(mu), k, n, nv)
    r = cones
    if capped:
        G[r + np.arange(k), nv + 3 * np.arange(k) + 2] = 1.0
        h[r : r + k] = np.asarray(upper, dtype=float)
        r += k
    for C, d in bounds:
        G[r : r + len(C), :nv] = C
        h[r : r + len(C)] = d
        r += len(C)
    U = np.zeros((0, 0)) if U is None else U
    return ContactQP(P, qv, A_eq, b_eq, G, h, Jc, U, cones)


def ramped_bound(force: float, time_to_lift: float, ramp: float, margin: float) -> float:
    """A loaded point's normal-force upper bound: its planned ``force`` plus a ``margin`` (same
    unit) that ramps linearly to zero over the last ``ramp`` [s] before the plan lifts the
    point (``time_to_lift`` [s]), so that a point carries nothing more than planned when it
    leaves the ground."""
    return force + margin * min(1.0, max(time_to_lift, 0.0) / ramp)


def frame_jacobians(model, data, frames) -> np.ndarray:
    """The linear rows (world axes) of the frames' Jacobians, stacked (3 per frame)."""
    lwa = pin.ReferenceFrame.LOCAL_WORLD_ALIGNED
    if not frames:
        return np.zeros((0, model.nv))
    return np.vstack([pin.getFrameJacobian(model, data, f, lwa)[:3] for f in frames])


def point_drifts(data, joints, local) -> np.ndarray:
    """Points' accelerations at dv = 0, J' v, world axes, (k, 3), from ``data``'s kinematics
    at dv = 0 (:func:`dynamics_terms`): the points at ``local`` (k, 3) in the frames of their
    ``joints`` (k,). A point r of a joint with velocity (v, w) and acceleration (a, alpha) in
    its axes: a + alpha x r + w x (v + w x r) = c + K r, with c = a + w x v and
    K = [alpha]x + w w^T - |w|^2 I (a point at rest on a moving chain, a stance foot under a
    walking body, has a few m/s^2 of it)."""
    out = np.empty((len(joints), 3))
    joints = np.asarray(joints, dtype=int)
    for j in set(joints.tolist()):
        vj, aj = data.v[j], data.a[j]
        w = vj.angular
        c = aj.linear + cross(w, vj.linear)
        K = np.outer(w, w)
        K.flat[::4] -= w @ w
        K += pin.skew(aj.angular)
        R = data.oMi[j].rotation
        on = joints == j
        out[on] = local[on] @ (R @ K).T + R @ c
    return out


def row_space(J: np.ndarray) -> np.ndarray:
    """An orthonormal basis U (m, r) of the span of J's columns (m, n), whose r combinations
    U^T J of J's rows are independent: the eigenvectors of J J^T with an eigenvalue above
    1e-12 of the largest (singular values above 1e-6 of the largest; a rigid body's points'
    rows have their dependent ones at 1e-16). For m < n, about half an SVD's cost (12 to 24
    rows of 39 columns: 15-54 us against 34-112)."""
    lam, V = np.linalg.eigh(J @ J.T)
    return V[:, lam > 1e-12 * lam[-1]]


def contact_qp(model, data, solver, found, loaded, free, tasks, M, hvec, q, v, dt: float,
               weight: float, gains, ranges, range_margin: float, range_time: float, *,
               drift=None, forces=None, upper=None) -> ContactQP:  # fmt: skip
    """:func:`whole_body_qp` on the plant's rigid ground.

    ``solver``: the plant's :class:`~humanoid.constraints.ground.ContactSolver` (its ground
    and its penetration correction); ``found``: its detection (:func:`feet_contacts`);
    ``loaded`` and ``free``: indices of its points that stick (their forces are unknowns) and
    that only must not go through the floor; ``tasks``: the costs on dv; ``gains``:
    ``w_force``, ``mu``, ``settle``, ``contact_time``, ``horizon``; ``forces``: the force
    tasks (None: ``w_force`` |f|^2, small forces); ``upper``: the loaded points' normal-force
    bounds [body weights].

    - Each loaded point's velocity is brought to rest over ``contact_time``
      (J (v + T dv) + gap = 0; a point still above the floor settles onto it over ``settle``),
      on an independent set of the rows (one sole's four points are twelve dependent rows:
      rank deficient equalities make the solver crawl).
    - Every free point is kept off the floor within the ``horizon`` H,
      -(J_n (v + H dv) + depth / H) <= 0 (the plant stops what is left within its step); the
      joint ranges are velocity dampers over H.

    ``drift``: the loaded points' accelerations at dv = 0 (J' v, world axes, 3 per point), or
    None. With it the sticking rows are J dv + J' v = -(J v + gap) / T: a point at rest on a
    moving chain (a stance foot under a walking body) has J' v of a few m/s^2, which the
    velocity-level rule alone leaves out.
    """
    phi = found.phi
    correction = solver.settings.correction
    nv = model.nv
    g = gains
    Jall = solver.ground.jacobian(data, found)
    depth = np.where(phi >= 0.0, phi, correction * phi)
    gap = depth / dt
    # the loaded points' three rows each, and the free points' normal rows (gathered)
    rows = (3 * np.asarray(loaded, dtype=int)[:, None] + np.arange(3)).ravel()
    Jc = Jall[rows] if loaded else np.zeros((0, nv))
    motion, U = [], None
    if loaded:
        target = -Jc @ v
        # the normal rows: in the floor, the gap's correction; above it, settling over settle
        at = np.asarray(loaded, dtype=int)
        if g.settle:
            target[2::3] -= np.where(phi[at] <= 0.0, gap[at], phi[at] / g.settle)
        else:
            target[2::3] -= gap[at]
        U = row_space(Jc)
        rate = target / max(dt, g.contact_time)
        if drift is not None:
            rate = rate - np.asarray(drift, dtype=float).ravel()
        motion.append((U.T @ Jc, U.T @ rate))
    bounds = []
    if free:
        Jn = Jall[3 * np.asarray(free, dtype=int) + 2]
        bounds.append((-Jn, (Jn @ v + depth[free] / g.horizon) / g.horizon))
    Jr, bound = range_damper(ranges, q, v, g.horizon, range_margin, range_time)
    bounds.append((-Jr, bound))
    return whole_body_qp(M, hvec, weight, tasks, Jc, g.mu, motion=motion, bounds=bounds,
                         forces=[ForceTask(0.0, g.w_force)] if forces is None else forces,
                         upper=upper,
                         U=U)  # fmt: skip


class JointWrenches:
    """Forces at points of a body's joints as Pinocchio's external forces (RNEA's ``fext``):
    each joint's resultant in its own frame, about its origin. A controller holding a QP's
    contact forces between its ticks takes its torques from them.

    Args:
        model: The Pinocchio model.
    """

    def __init__(self, model: pin.Model) -> None:
        self.fext = pin.StdVec_Force()
        for _ in range(model.njoints):
            self.fext.append(pin.Force.Zero())
        self._loaded: list[int] = []  # the joints the last call wrote

    def set(self, data: pin.Data, joints, local: np.ndarray, f: np.ndarray) -> pin.StdVec_Force:
        """The forces ``f`` (k, 3, world axes) at the points ``local`` (k, 3, each in its
        joint's frame) of ``joints`` (k,), with ``data``'s joint placements: ``fext`` (the same
        object at every call; the joints the last call loaded and this one does not are
        zeroed)."""
        ids = np.asarray(joints, dtype=int)
        return self.set_local(ids, local, self.local_forces(data, ids, f))

    @staticmethod
    def local_forces(data: pin.Data, joints, f: np.ndarray) -> np.ndarray:
        """The forces ``f`` (k, 3, world axes) in the axes of their ``joints`` (k,) at
        ``data``'s placements."""
        ids = np.asarray(joints, dtype=int)
        out = np.empty((len(ids), 3))
        for j in dict.fromkeys(ids.tolist()):
            on = ids == j
            out[on] = f[on] @ data.oMi[j].rotation  # R^T f: the joint's axes
        return out

    def set_local(self, joints, local: np.ndarray, f: np.ndarray) -> pin.StdVec_Force:
        """:meth:`set` with the forces ``f`` already in their joints' axes."""
        fext = self.fext
        ids = np.asarray(joints, dtype=int)
        loaded = list(dict.fromkeys(ids.tolist()))
        for j in self._loaded:
            if j not in loaded:
                fext[j] = pin.Force.Zero()
        self._loaded = loaded
        for j in loaded:
            if len(loaded) == 1:
                f_j, r_j = f, local
            else:
                on = ids == j
                f_j, r_j = f[on], local[on]
            # sum r x f: the antisymmetric part of sum r f^T
            c = (r_j.T @ f_j).ravel().tolist()
            fext[j] = pin.Force(np.array([*f_j.sum(axis=0).tolist(), c[5] - c[7], c[6] - c[2],
                                          c[1] - c[3]]))  # fmt: skip
        return fext
