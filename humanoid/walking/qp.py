"""What the walking controllers' QPs share: the warm-started ProxQP solve, the friction pyramid
of a set of contact points, and the joint ranges' velocity dampers."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import pinocchio as pin

__all__ = [
    "ContactQP",
    "WarmQP",
    "contact_qp",
    "dynamics_terms",
    "feet_contacts",
    "pyramid_rows",
    "range_damper",
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
        self._qp = None
        self._dims = None
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


def pyramid_rows(mu: float, points: int, columns: int, offset: int) -> np.ndarray:
    """G rows (G x <= 0) keeping each point's force (x[offset + 3 i : offset + 3 i + 3], world
    axes, z up) in a friction pyramid inscribed in the cone of coefficient ``mu``:
    f_z >= 0 and |f_x|, |f_y| <= (mu / sqrt 2) f_z."""
    m = mu / np.sqrt(2.0)
    pyramid = np.array([[0, 0, -1.0], [1, 0, -m], [-1, 0, -m], [0, 1, -m], [0, -1, -m]])
    G = np.zeros((5 * points, columns))
    for i in range(points):
        G[5 * i : 5 * i + 5, offset + 3 * i : offset + 3 * i + 3] = pyramid
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


def frame_task(model, data, rdata, fid: int, kp: float, kd: float, shift=None):
    """A frame's pose task on dv: (J, rhs) with J dv = rhs the PD law around the reference's
    classical acceleration (LOCAL_WORLD_ALIGNED), the reference read from ``rdata`` (its
    kinematics up to date), moved by ``shift`` (x, y) [m] if given."""
    lwa = pin.ReferenceFrame.LOCAL_WORLD_ALIGNED
    J = pin.getFrameJacobian(model, data, fid, lwa)
    vel = pin.getFrameVelocity(model, data, fid, lwa)
    acc = pin.getFrameClassicalAcceleration(model, data, fid, lwa)
    M_f, M_r = data.oMf[fid], rdata.oMf[fid].copy()
    if shift is not None:
        M_r.translation[:2] += shift
    vr = pin.getFrameVelocity(model, rdata, fid, lwa)
    ar = pin.getFrameClassicalAcceleration(model, rdata, fid, lwa)
    lin = ar.linear + kp * (M_r.translation - M_f.translation) + kd * (vr.linear - vel.linear)
    ang = (
        ar.angular
        + kp * (M_f.rotation @ pin.log3(M_f.rotation.T @ M_r.rotation))
        + kd * (vr.angular - vel.angular)
    )
    return J, np.concatenate([lin - acc.linear, ang - acc.angular])


def feet_contacts(ground, model, data, foot_joint: dict):
    """The plant's own ground detection (constraint models and datas, signed distances, world
    points) and, per point, the side whose foot it is on (None: another body)."""
    cms, cds, phi, points = ground.ground.detect(model, data)
    side_of = [next((s for s, j in foot_joint.items() if j == cm.extract().joint2_id), None)
               for cm in cms]  # fmt: skip
    return cms, cds, phi, points, side_of


@dataclass
class ContactQP:
    """A task-space inverse-dynamics QP over x = (dv, f / weight) (see :func:`contact_qp`):
    minimise 1/2 x'Px + q'x subject to A x = b, G x <= h. ``Jc``: the loaded points'
    Jacobian (3 rows each); ``U``: the independent combinations of its rows that the sticking
    equalities use (after the root's 6 rows of A); ``cones``: how many rows of G, first, keep
    the forces in their pyramids."""

    P: np.ndarray
    q: np.ndarray
    A: np.ndarray
    b: np.ndarray
    G: np.ndarray
    h: np.ndarray
    Jc: np.ndarray
    U: np.ndarray
    cones: int


def contact_qp(model, data, contacts, loaded, free, tasks, M, hvec, q, v, dt: float,
               weight: float, gains, ranges, correction: float,
               range_margin: float, range_time: float, drift=None) -> ContactQP:  # fmt: skip
    """The walking and tracking controllers' QP on the rigid ground.

    ``contacts``: the plant's detection (constraint models and datas, signed distances);
    ``loaded`` and ``free``: indices of its points that stick (their forces are unknowns) and
    that only must not go through the floor; ``tasks``: (rows, right-hand sides, weights) of the
    costs on dv; ``gains``: ``w_force``, ``mu``, ``settle``, ``contact_time``, ``horizon``.

    - Equalities: the free flyer's six rows of the dynamics (never actuated); each loaded
      point's velocity brought to rest over ``contact_time`` (J (v + T dv) + gap = 0; a point
      still above the floor settles onto it over ``settle``), on an independent set of the
      rows (one sole's four points are twelve dependent rows: rank deficient equalities make
      the solver crawl).
    - Inequalities: the loaded points' forces in friction pyramids; every free point kept off
      the floor within the ``horizon`` H, -(J_n (v + H dv) + depth / H) <= 0 (the plant stops
      what is left within its step); the joint ranges as velocity dampers over H.
    - Costs: the tasks, and small forces (``w_force``).

    ``drift``: the loaded points' accelerations at dv = 0 (J' v, world axes, 3 per point), or
    None. With it the sticking rows are J dv + J' v = -(J v + gap) / T: a point at rest on a
    moving chain (a stance foot under a walking body) has J' v of a few m/s^2, which the
    velocity-level rule alone leaves out.
    """
    cms, cds, phi = contacts
    nv = model.nv
    g = gains
    for cm, cd in zip(cms, cds, strict=True):
        cm.calc(model, data, cd)
    Jall = pin.getConstraintsJacobian(model, data, cms, cds) if cms else np.zeros((0, nv))
    depth = np.where(phi >= 0.0, phi, correction * phi)
    gap = depth / dt
    nf = 3 * len(loaded)
    n = nv + nf
    Jc = np.vstack([Jall[3 * i : 3 * i + 3] for i in loaded]) if loaded else np.zeros((0, nv))
    rows, rhs, weights = tasks
    A_cost = np.hstack([np.vstack(rows), np.zeros((sum(len(r) for r in rows), nf))])
    W = np.concatenate(weights)
    P = A_cost.T @ (W[:, None] * A_cost)
    qv = -A_cost.T @ (W * np.concatenate(rhs))
    P[nv:, nv:] += g.w_force * np.eye(nf)
    A_eq = [np.hstack([M[:6], -weight * Jc.T[:6]])]
    b_eq = [-hvec[:6]]
    U = np.zeros((0, 0))
    if loaded:
        target = -Jc @ v
        for j, i in enumerate(loaded):
            target[3 * j + 2] -= gap[i] if phi[i] <= 0.0 or not g.settle else phi[i] / g.settle
        U, S, _ = np.linalg.svd(Jc, full_matrices=False)
        U = U[:, S > 1e-9 * S[0]]
        A_eq.append(np.hstack([U.T @ Jc, np.zeros((U.shape[1], nf))]))
        rate = target / max(dt, g.contact_time)
        if drift is not None:
            rate = rate - np.asarray(drift, dtype=float).ravel()
        b_eq.append(U.T @ rate)
    G = [pyramid_rows(g.mu, len(loaded), n, nv)]
    h_ineq = [np.zeros(5 * len(loaded))]
    if free:
        Jn = np.vstack([Jall[3 * i + 2] for i in free])
        G.append(np.hstack([-Jn, np.zeros((len(free), nf))]))
        h_ineq.append((Jn @ v + depth[free] / g.horizon) / g.horizon)
    Jr, bound = range_damper(ranges, q, v, g.horizon, range_margin, range_time)
    if len(Jr):
        G.append(np.hstack([-Jr, np.zeros((len(Jr), nf))]))
        h_ineq.append(bound)
    return ContactQP(P, qv, np.vstack(A_eq), np.concatenate(b_eq), np.vstack(G),
                     np.concatenate(h_ineq), Jc, U, 5 * len(loaded))  # fmt: skip
