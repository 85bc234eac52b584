"""Direct collocation of a body's motion through its rigid contact dynamics, solved by IPOPT.

The motion is a sequence of :class:`Phase` s, each with the contact points that stick to the
floor during it. It runs on an :class:`~humanoid.optimal.coordinates.OcpModel` (every
coordinate an angle or a length). Decision variables at every node k: the configuration x_k,
velocity v_k and acceleration a_k, and a force f_kp [body weights, world axes] at each point
in contact. Constraints:

- **Dynamics, implicit** (inverse dynamics at the nodes, as Puchaud, Bailly & Begon 2023 found
  converging more often than forward dynamics): the root's six generalised forces of
  RNEA(x_k, v_k, a_k) - sum_p J_p^T f_kp are zero (the pelvis is not actuated); the joints'
  are the torques, expressions of the variables rather than variables.
- **Collocation defects** (trapezoidal): x_{k+1} = x_k + h (v_k + v_{k+1}) / 2 and
  v_{k+1} = v_k + h (a_k + a_{k+1}) / 2, h the phase's interval.
- **Contacts**: a point in contact stays at its anchor on the floor (z = 0) for as long as it
  stays down, and its velocity is zero at the node it lands (the independent rows of those,
  see :class:`Collocation`); its force lies in the friction pyramid |f_x|, |f_y| <= mu /
  sqrt(2) f_z (inscribed in the cone) with f_z >= 0. Points not in contact stay above the
  floor. Joint ranges are bounds.

The objective is the caller's (:mod:`humanoid.optimal.gait` writes a walk's).
"""

from __future__ import annotations

import math
import time
from typing import Any

import numpy as np
import pinocchio as pin

from ..errors import OptimalControlError
from ._casadi import ca
from .cycle import Phase, Solution
from .dynamics import SymbolicModel

__all__ = ["Collocation", "Phase", "Solution"]  # Phase, Solution: from .cycle

G = 9.81


class Collocation:
    """A motion of the body ``om`` through ``phases`` as a nonlinear program (see the module).

    Args:
        om: The body in vector-space coordinates (:func:`build_ocp_model`).
        phases: The phases in order.
        mu: Coulomb friction coefficient of the floor.
        clearance: Points (frame names) that must stay on or above the floor when not in
            contact (default: every contact frame of any phase).
        periodic: The caller ties the last node's state to the first's (a periodic or
            mirrored motion): the last node then writes no contact, clearance or range
            constraints, which would repeat the first node's (IPOPT needs independent
            equality constraints).
        range_margin: [rad or m] the joints stay this far inside their ranges (a motion to
            be tracked on a plant that enforces the ranges must not ride them).

    Contacts are written with independent rows only: of the (x, y, z) of the points in
    contact at a node, the largest set whose Jacobian rows are independent at the standing
    posture (z rows first), so that a flat foot's four corners give six equations, not twelve
    (IPOPT needs independent equality constraints); the others follow from the rigid geometry.
    A point's (x, y) anchor is one variable over the consecutive phases it stays down in.
    """

    def __init__(self, om, phases, mu: float = 0.8, clearance=None, periodic=False,
                 range_margin: float = 0.0) -> None:  # fmt: skip
        if not phases:
            raise OptimalControlError("a collocation needs at least one phase")
        self.om, self.phases, self.mu = om, tuple(phases), float(mu)
        self.periodic = bool(periodic)
        self.range_margin = float(range_margin)
        self.n = om.n
        self.weight = float(sum(i.mass for i in om.model.inertias)) * G
        points = sorted({p for ph in self.phases for p in ph.contacts})
        self.points = points
        self.clearance = tuple(points if clearance is None else clearance)
        self._functions()
        self.opti = opti = ca.Opti()
        self.N = N = sum(ph.intervals for ph in self.phases)
        self.X = opti.variable(self.n, N + 1)
        self.V = opti.variable(self.n, N + 1)
        self.A = opti.variable(self.n, N + 1)
        self.durations: list = []  # per phase: its duration [s] (a variable or a number)
        self.F: dict[tuple, Any] = {}  # (node, point) -> 3-vector [N]
        self._f: dict[tuple, Any] = {}  # (node, point) -> its variable [body weights]
        # (point, first phase of its stay, axis) -> scalar variable
        self.anchors: dict[tuple, Any] = {}
        self.tau: list = []  # per node: the joints' torques (expressions)
        self._reference = om.from_body(om.body.standing_configuration())
        self._row_cache: dict = {}
        self._build()

    # -- the model's functions -------------------------------------------------------------
    def _functions(self) -> None:
        sm = SymbolicModel(self.om.model)
        n, P = self.n, max(len(self.points), 1)
        x, v, a = (ca.SX.sym(s, n) for s in "xva")
        f = ca.SX.sym("f", 3, P)
        forces = [(p, f[:, i]) for i, p in enumerate(self.points)]
        self.inverse_dynamics = ca.Function("id", [x, v, a, f], [sm.rnea(x, v, a, forces)])
        kin = sm.kinematics(x, v)
        pos = [sm.frame_placement(kin, p)[1] for p in self.points] or [ca.SX.zeros(3, 1)]
        vel = [sm.frame_velocity(kin, p)[:3] for p in self.points] or [ca.SX.zeros(3, 1)]
        self.point_pos = ca.Function("pos", [x], [ca.horzcat(*pos)])
        self.point_vel = ca.Function("vel", [x, v], [ca.horzcat(*vel)])

    # -- the program -----------------------------------------------------------------------
    def _build(self) -> None:
        opti, model = self.opti, self.om.model
        k0 = 0
        for ph in self.phases:
            if ph.free is None:
                T = ph.duration
            else:
                T = opti.variable()
                opti.subject_to(opti.bounded(ph.free[0], T, ph.free[1]))
                opti.set_initial(T, ph.duration)
            self.durations.append(T)
            h = T / ph.intervals
            for k in range(k0, k0 + ph.intervals):
                x0, x1 = self.X[:, k], self.X[:, k + 1]
                v0, v1 = self.V[:, k], self.V[:, k + 1]
                a0, a1 = self.A[:, k], self.A[:, k + 1]
                opti.subject_to(x1 == x0 + h * (v0 + v1) / 2)
                opti.subject_to(v1 == v0 + h * (a0 + a1) / 2)
            k0 += ph.intervals
        sets = _contact_sets(self.phases)
        ranged, lo, hi = _range_bounds(model, self.range_margin)
        c = self.mu / math.sqrt(2.0)
        for k in range(self.N + 1):
            acting, held, landing = sets[k]
            fk = []
            for p in self.points:
                if p in acting:
                    f = opti.variable(3)
                    self._f[k, p] = f
                    self.F[k, p] = self.weight * f
                    opti.subject_to(f[2] >= 0)
                    opti.subject_to(opti.bounded(-c * f[2], f[0], c * f[2]))
                    opti.subject_to(opti.bounded(-c * f[2], f[1], c * f[2]))
                    fk.append(self.F[k, p])
                else:
                    fk.append(ca.DM.zeros(3))
            F = ca.horzcat(*fk) if fk else ca.DM.zeros(3, 1)
            tau = self.inverse_dynamics(self.X[:, k], self.V[:, k], self.A[:, k], F)
            opti.subject_to(tau[:6] / self.weight == 0)
            self.tau.append(tau[6:])
            if self.periodic and k == self.N:
                continue
            pos = self.point_pos(self.X[:, k])
            vel = self.point_vel(self.X[:, k], self.V[:, k]) if landing else None
            down = set()
            for (p, axis), stay in self._rows(held):
                i = self.points.index(p)
                down.add(p)
                if axis == 2:
                    opti.subject_to(pos[2, i] == 0)
                else:
                    opti.subject_to(pos[axis, i] == self._anchor(p, stay, axis))
                if p in landing:
                    assert vel is not None  # computed when a point lands
                    opti.subject_to(vel[axis, i] == 0)
            for p in self.clearance:
                if p not in down and p not in {q for q, _ in held}:
                    opti.subject_to(pos[2, self.points.index(p)] >= 0)
            opti.subject_to(opti.bounded(lo[ranged], self.X[ranged, k], hi[ranged]))

    def _rows(self, held):
        """The independent (point, axis) rows of the points held, z rows first, with each
        point's stay."""
        if held not in self._row_cache:
            self._row_cache[held] = _independent_rows(self.om.model, self._reference, held)
        return self._row_cache[held]

    def _anchor(self, point, stay, axis):
        key = (point, stay, axis)
        if key not in self.anchors:
            self.anchors[key] = self.opti.variable()
        return self.anchors[key]

    # -- helpers for objectives ------------------------------------------------------------
    def node_times(self):
        """Node times [s] (expressions where durations are free)."""
        t, out = 0, []
        for ph, T in zip(self.phases, self.durations, strict=True):
            out += [t + T * j / ph.intervals for j in range(ph.intervals)]
            t = t + T
        return out + [t]

    def node_weights(self):
        """Trapezoidal quadrature weights [s] (expressions where durations are free)."""
        out = [0] * (self.N + 1)
        k = 0
        for ph, T in zip(self.phases, self.durations, strict=True):
            h = T / ph.intervals
            for j in range(ph.intervals + 1):
                out[k + j] = out[k + j] + (h / 2 if j in (0, ph.intervals) else h)
            k += ph.intervals
        return out

    def total_duration(self):
        return sum(self.durations)

    def foot_force(self, k: int, points) -> ca.MX:
        """The summed force [N] of ``points`` at node k (zero for those not in contact)."""
        out = ca.MX.zeros(3, 1)
        for p in points:
            if (k, p) in self.F:
                out = out + self.F[k, p]
        return out

    def effort(self, scale=None):
        """Integral of sum_j (tau_j / scale_j)^2 dt (scale: the joints' effort limits by
        default)."""
        if scale is None:
            scale = np.maximum(self.om.model.effortLimit[6:], 1.0)
        w = self.node_weights()
        return sum(w[k] * ca.sumsqr(self.tau[k] / scale) for k in range(self.N + 1))

    def force_regulariser(self):
        """Sum over nodes and points of |f|^2 [body weights^2] (picks one of the contact
        forces that a rigid foot leaves undetermined)."""
        return sum(ca.sumsqr(f) for f in self._f.values())

    # -- guesses and solving ---------------------------------------------------------------
    def guess(self, x, v=None, a=None, durations=None) -> None:
        """Initial guess: x (N + 1, n) or one configuration for every node; forces share the
        body's weight among the points in contact."""
        x = np.broadcast_to(np.asarray(x, dtype=float), (self.N + 1, self.n))
        self.opti.set_initial(self.X, x.T)
        if v is not None:
            self.opti.set_initial(self.V, np.broadcast_to(v, (self.N + 1, self.n)).T)
        if a is not None:
            self.opti.set_initial(self.A, np.broadcast_to(a, (self.N + 1, self.n)).T)
        if durations is not None:
            for d, T in zip(durations, self.durations, strict=True):
                if isinstance(T, ca.MX):
                    self.opti.set_initial(T, d)
        count: dict[int, int] = {}
        for k, _ in self._f:
            count[k] = count.get(k, 0) + 1
        for (k, _), f in self._f.items():
            self.opti.set_initial(f, [0.0, 0.0, 1.0 / count[k]])
        starts = np.concatenate([[0], np.cumsum([ph.intervals for ph in self.phases])])
        for (p, stay, axis), anchor in self.anchors.items():
            pos = np.array(self.point_pos(x[int(starts[stay])])).reshape(3, -1)
            self.opti.set_initial(anchor, pos[axis, self.points.index(p)])

    def warm_start(self, sol: Solution) -> None:
        """Start from a solution of the same problem (same phases and nodes)."""
        self.guess(sol.x, sol.v, sol.a, sol.durations)
        for (k, p), f in self._f.items():
            self.opti.set_initial(f, sol.forces[p][k] / self.weight)

    def solve(self, objective, *, terms=None, max_iter: int = 3000, tol: float = 1e-6,
              verbose: bool = False, options=None) -> Solution:  # fmt: skip
        """Minimise ``objective`` with IPOPT (exact Hessian, MUMPS). ``terms``: named parts of
        the objective whose values the solution reports."""
        opti = self.opti
        opti.minimize(objective)
        opts: dict[str, Any] = {
            "ipopt.max_iter": max_iter,
            "ipopt.tol": tol,
            "ipopt.constr_viol_tol": 1e-8,
        }
        opts |= {"ipopt.print_level": 5 if verbose else 0, "print_time": False}
        opts |= {"ipopt.sb": "yes", "expand": True}
        opts |= dict(options or {})
        opti.solver("ipopt", opts)
        start = time.perf_counter()
        try:
            sol = opti.solve()
            value, success = sol.value, True
        except RuntimeError:
            value, success = opti.debug.value, False
        seconds = time.perf_counter() - start
        return _solution(self, value, success, opti.stats(), seconds, objective, terms or {})


def _solution(col: Collocation, value, success, stats, seconds, objective, terms) -> Solution:
    """The :class:`Solution` of ``col`` read with ``value`` (its states, durations, forces
    [N] and torques, the largest collocation defect and root residual)."""
    X, V, A = (np.array(value(z)).reshape(z.shape).T for z in (col.X, col.V, col.A))
    T = np.array([float(value(d)) if isinstance(d, ca.MX) else float(d)
                  for d in col.durations])  # fmt: skip
    t = [0.0]
    for ph, d in zip(col.phases, T, strict=True):
        t += list(t[-1] + d * np.arange(1, ph.intervals + 1) / ph.intervals)
    forces = {p: np.zeros((col.N + 1, 3)) for p in col.points}
    for (k, p), f in col._f.items():
        forces[p][k] = np.array(value(f)).ravel() * col.weight
    defect, k0 = 0.0, 0
    for ph, d in zip(col.phases, T, strict=True):
        h = d / ph.intervals
        for k in range(k0, k0 + ph.intervals):
            defect = max(defect, np.abs(X[k] + h * (V[k] + V[k + 1]) / 2 - X[k + 1]).max())
            defect = max(defect, np.abs(V[k] + h * (A[k] + A[k + 1]) / 2 - V[k + 1]).max())
        k0 += ph.intervals
    tau = np.zeros((col.N + 1, col.n))
    for k in range(col.N + 1):
        F = np.column_stack([forces[p][k] for p in col.points] or [np.zeros(3)])
        tau[k] = np.array(col.inverse_dynamics(X[k], V[k], A[k], F)).ravel()
    return Solution(
        np.array(t), X, V, A, tau, forces, T, success, stats.get("return_status", "?"),
        int(stats.get("iter_count", -1)), seconds, float(defect),
        float(np.abs(tau[:, :6]).max()), float(value(objective)),
        {name: float(value(term)) for name, term in terms.items()},
    )  # fmt: skip


def _contact_sets(phases):
    """Per node: the points whose forces act there, the points held down there with the
    first phase of their stay (a boundary node holds the points leaving too), and the
    points that land there."""
    first = {}  # (point, phase) -> the first phase of the stay it belongs to
    for i, ph in enumerate(phases):
        for p in ph.contacts:
            first[p, i] = first.get((p, i - 1), i)
    out = []
    for i, ph in enumerate(phases):
        for k in range(ph.intervals + (1 if i == len(phases) - 1 else 0)):
            held = {(p, first[p, i]) for p in ph.contacts}
            landing = set()
            if k == 0:
                landing = {p for p in ph.contacts if first[p, i] == i}
            if k == 0 and i > 0:
                held |= {(p, first[p, i - 1]) for p in phases[i - 1].contacts
                         if p not in ph.contacts}  # fmt: skip
            out.append((set(ph.contacts), frozenset(held), landing))
    return out


def _independent_rows(model, q, held):
    """The largest set of (point, axis) rows of the points held ((point, stay) pairs) whose
    Jacobian rows at ``q`` are independent, z rows first: [((point, axis), stay)]."""
    data = model.createData()
    pin.computeJointJacobians(model, data, q)
    pin.updateFramePlacements(model, data)
    lwa = pin.ReferenceFrame.LOCAL_WORLD_ALIGNED
    order = sorted(held)
    J = {p: pin.getFrameJacobian(model, data, model.getFrameId(p), lwa)[:3]
         for p, _ in order}  # fmt: skip
    basis, rows = [], []
    for axis in (2, 0, 1):
        for p, stay in order:
            r = J[p][axis].copy()
            norm = np.linalg.norm(r)
            for b in basis:
                r -= (b @ r) * b
            if np.linalg.norm(r) > 1e-8 * max(norm, 1.0):
                basis.append(r / np.linalg.norm(r))
                rows.append(((p, axis), stay))
    return rows


def _range_bounds(model, range_margin: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(the coordinates with a finite range under 100, their lower and upper bounds moved
    ``range_margin`` inside, at most a quarter of the range each)."""
    lo, hi = model.lowerPositionLimit, model.upperPositionLimit
    ranged = np.flatnonzero(np.isfinite(lo) & np.isfinite(hi) & (hi - lo < 100))
    margin = np.minimum(range_margin, 0.25 * (hi[ranged] - lo[ranged]))
    lo, hi = lo.copy(), hi.copy()
    lo[ranged] += margin
    hi[ranged] -= margin
    return ranged, lo, hi
