"""Starting a walk from standing and stopping it standing.

A person starts walking by shifting the weight onto one foot while the centre of mass begins to
move forward (the centre of pressure goes back and towards the foot that will swing, then onto
the stance foot: gait initiation), swings the other foot into the first step, and reaches the
steady gait within a step or two. A person stops by braking over the last steps (the centre of
pressure moves to the front of the leading foot) and bringing the trailing foot beside the
leading one.

:func:`start_stop` makes both out of a body's fitted gait cycle, for the whole-body controller
(:class:`~humanoid.walking.tracking.GaitController`) that tracks the cycle:

- **The clock.** The cycle's clock holds at the trailing foot's foot off until ``t_go`` (both
  feet flat and bearing, the weight shifting) and again once the closing foot is flat
  (``t_stop``): the cycle is followed in between, as in a steady walk.
- **The feet.** The body stands with its feet side by side where its reference posture puts
  them; the footsteps of the cycle are carried onto them (the controller's anchors), so the
  first swing takes the left foot from beside the right one to a full step ahead. The braking
  steps are shortened, each by how far the braking body is behind the cycle's at its heel
  strike (else the leg cannot reach the floor); the last braking foot stays flat to the end;
  the closing foot lands beside it (its footstep moved back by a step length).
- **The centre of mass.** Over the start and over the stop, its path across and along is the
  one whose zero-moment point is nearest (least squares) the cycle's plan -- the standing
  feet's middle before the first step, each stance foot's rolling centre of pressure, the
  middle of the feet once stopped -- among the paths that leave standing still (or the steady
  cycle's centre of mass, position and velocity) and reach the steady cycle's centre of mass
  at the second right heel strike (or the feet's middle, at rest). Over the stop the
  zero-moment point is kept inside the parts of the soles that bear load, and the
  accelerations are spread over the braking steps (:func:`pendulum_path`, a QP). Its height
  moves between the standing height and the cycle's along a smooth step (over the stop, the
  cycle's height where the centre of mass is relative to the footsteps, not when). The
  posture the controller's joints lean to moves the same way between the reference posture
  and the cycle's.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
import pinocchio as pin
from scipy.linalg import solve_banded

from ..control.qp import WarmQP
from ..errors import WalkError
from ..model import SIDES
from .plan import smooth_step
from .tracking import contact_kind, footstep_phase

__all__ = ["ComPiece", "StartStop", "pendulum_path", "start_stop"]

SAMPLE = 5e-3  # [s] the planned centre of mass's samples
GO = 0.6  # [s] standing, shifting the weight, before the first foot leaves the floor
REST = 1.0  # [s] standing still at the end
MERGE = 1.0  # [cycle] the start's plan joins the steady cycle's here
LEAN = 0.3  # [s] the centre of mass rises to its standing height this long after the clock stops
SHORTEN_ITERATIONS = 20
MARGIN = 0.01  # [m] the planned zero-moment point stays this far inside the support
# [cycle] the stop's plan leaves the steady cycle this long before the braking foot lands
BRAKE = 1.5
# weight of the accelerations in the stop's plan (at 1 the braking all fell in the last stance
# and the body stopping from 1.0 m/s fell; at 10 it stops; at 100 and BRAKE 2.5, 5 of 9 stops
# from 1.0-1.4 m/s, no better than now)
SMOOTH = 10.0


def pendulum_path(p: np.ndarray, omega2: float, dt: float, start: tuple, end: tuple,
                  bounds: tuple | None = None, smooth: float = 0.0) -> np.ndarray:  # fmt: skip
    """The path c (n, d) of an inverted pendulum's mass whose zero-moment point
    c - c'' / omega2 is nearest, in least squares, to ``p`` (n, d) at the inner samples, among
    the paths that leave ``start`` = (c, c') and reach ``end`` = (c, c') exactly (first and last
    two samples; central second differences, ``dt`` apart), and, with ``bounds`` = (lo, hi),
    each (n, d), whose zero-moment point stays inside them (a QP, ProxQP)."""
    p = np.asarray(p, dtype=float)
    n = len(p)
    if n < 6:
        raise WalkError(f"a pendulum path needs at least 6 samples, got {n}")
    # zero-moment point rows for the inner samples 1..n-2
    A = np.zeros((n - 2, n))
    k = 1.0 / (omega2 * dt * dt)
    for i in range(1, n - 1):
        A[i - 1, i - 1 : i + 2] = (-k, 1.0 + 2.0 * k, -k)
    C = np.zeros((4, n))
    C[0, 0] = C[1, 1] = C[2, -2] = C[3, -1] = 1.0
    (c0, v0), (c1, v1) = (
        (np.asarray(x, dtype=float) for x in start),
        (np.asarray(x, dtype=float) for x in end),
    )
    d = np.stack([c0 - 0.5 * dt * v0, c0 + 0.5 * dt * v0, c1 - 0.5 * dt * v1, c1 + 0.5 * dt * v1])
    if bounds is None:
        K = np.block([[A.T @ A, C.T], [C, np.zeros((4, 4))]])
        rhs = np.vstack([A.T @ p[1:-1], d])
        return np.linalg.solve(K, rhs)[:n]
    # with bounds: the zero-moment points P (samples 1..n-2) are the unknowns (the path as a
    # function of them is well conditioned; the path's own normal equations are not, k ~ 4e3).
    # The rows 2..n-3 give the inner path c_in = T^-1 (P_mid + b); rows 1 and n-2 constrain P
    lo, hi = (np.asarray(b, dtype=float)[1:-1] for b in bounds)
    m = n - 4
    band = np.zeros((3, m))
    band[0, 1:], band[1], band[2, :-1] = -k, 1.0 + 2.0 * k, -k
    ends = np.zeros((m, 2))
    ends[0, 0] = ends[-1, 1] = 1.0
    r = solve_banded((1, 1), band, ends)  # T^-1 e_first, T^-1 e_last (T is symmetric)
    out = np.empty((n, p.shape[1]))
    for j in range(p.shape[1]):
        c = np.array([d[0, j], d[1, j], d[2, j], d[3, j]])
        b = np.zeros(m)
        b[0] += k * c[1]
        b[-1] += k * c[2]
        E = np.zeros((2, n - 2))
        E[0, 0], E[0, 1:-1] = 1.0, k * r[:, 0]
        E[1, -1], E[1, 1:-1] = 1.0, k * r[:, 1]
        f = np.array([-k * c[0] + (1 + 2 * k) * c[1] - k * r[:, 0] @ b,
                      (1 + 2 * k) * c[2] - k * c[3] - k * r[:, 1] @ b])  # fmt: skip
        keep = np.isfinite(lo[:, j]), np.isfinite(hi[:, j])
        eye = np.eye(n - 2)
        G = np.vstack([-eye[keep[0]], eye[keep[1]]])
        h = np.concatenate([-lo[keep[0], j], hi[keep[1], j]])
        H, g = np.eye(n - 2), -p[1:-1, j]
        if smooth and (keep[0].any() or keep[1].any()):  # + smooth |c - P|^2 (bounded axes):
            # the accelerations spread out, not all in the last stance
            Tinv = solve_banded((1, 1), band, np.eye(m))
            K = np.zeros((n - 2, n - 2))
            K[1:-1, 1:-1] = Tinv
            k0 = np.concatenate([[c[1]], Tinv @ b, [c[2]]])
            D = K - np.eye(n - 2)
            H = H + smooth * D.T @ D
            g = g + smooth * D.T @ k0
        qp = WarmQP(eps_abs=1e-9, max_iter=1000, primal=1e-7, dual=1e-6)
        P = qp.solve(H, g, E, f, G, h)
        if P is None:
            raise WalkError(
                f"no centre-of-mass path keeps its zero-moment point in the support ({qp.why})"
            )
        out[:, j] = np.concatenate([c[:2], solve_banded((1, 1), band, P[1:-1] + b), c[2:]])
    return out


@dataclass
class ComPiece:
    """The centre of mass planned over [t[0], t[-1]] in the cycle's own frame (carried by the
    anchor of ``side``'s footstep ``k``): positions, velocities, accelerations (n, 3)."""

    t: np.ndarray
    c: np.ndarray
    dc: np.ndarray
    ddc: np.ndarray
    side: str
    k: int

    def at(self, t: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        c, dc, ddc = (
            np.array([np.interp(t, self.t, x[:, i]) for i in range(3)])
            for x in (self.c, self.dc, self.ddc)
        )
        return c, dc, ddc


@dataclass
class StartStop:
    """A walk's start from standing and stop standing (see the module docstring).

    Attributes:
        q0: the standing configuration the walk starts from (at rest), and the joints' target
            while standing.
        phase0: the cycle's phase while the weight shifts (the left foot's foot off).
        t_go: when the cycle's clock starts [s]. t_stop: when it stops again. t_end: the walk's
            end (standing still since ``t_stop``).
        anchors: each side's footstep 0 placement (x, y, yaw) relative to the cycle's.
        brake: (side, footstep) of the last stance that ends standing: its foot stays flat.
        closing: (side, footstep) of the closing foot, landing beside the braking one.
        moved: (side, footstep) -> how far it is moved back [m] from where the footstep before
            it puts it: the braking steps a little each, the closing one a step length.
        start, stop: the centre of mass's plans over the start and the stop.
        steps: heel strikes, the closing one included. period: the cycle's [s].
        stop_from: when the braking foot is flat [s]. lean_from: when the closing foot lands
            and the centre of mass's height and the joints start leaning to standing again
            (earlier, the legs could not reach the floor: the braking foot hovered 2 cm up).
    """

    q0: np.ndarray
    phase0: float
    t_go: float
    t_stop: float
    t_end: float
    anchors: dict
    brake: tuple
    closing: tuple
    moved: dict
    start: ComPiece
    stop: ComPiece
    steps: int
    period: float
    stop_from: float
    lean_from: float

    def time(self, phase: float) -> float:
        """When the cycle's clock shows ``phase`` (between the holds)."""
        return self.t_go + (phase - self.phase0) * self.period

    @property
    def start_anchor(self) -> tuple[str, int]:
        """The footstep whose anchor carries the start's plan: the right foot's first."""
        return self.start.side, self.start.k

    def hold(self) -> tuple[float, float]:
        return self.t_go, self.t_stop

    def piece(self, t: float) -> ComPiece | None:
        for p in (self.start, self.stop):
            if p.t[0] <= t <= p.t[-1] or (p is self.stop and t > p.t[-1]):
                return p
        return None

    def standing_weight(self, t: float) -> float:
        """How much the joints lean to the standing posture rather than the cycle's (0-1)."""
        t_land = self.time(0.5)  # the first step's landing
        if t <= self.t_go:
            return 1.0
        if t < t_land:
            return 1.0 - float(smooth_step((t - self.t_go) / (t_land - self.t_go)))
        t0 = self.lean_from
        return float(smooth_step((t - t0) / (self.t_stop + LEAN - t0))) if t > t0 else 0.0


def _footstep(cycle, side: str) -> np.ndarray:
    """(x, y) of a side's footstep 0 in the cycle (its sole while flat, one stride back for
    the left, whose flat foot in the first lap is on footstep 1)."""
    i = int(np.flatnonzero(cycle.contact[side] == 2)[0])
    x, y = cycle.feet[side][i, :2]
    k = math.floor(cycle.phase[i] + (0.5 if side == "left" else 0.0))
    return np.array([x - cycle.stride * k, y])


@dataclass(frozen=True)
class _Clock:
    """The cycle's clock of a walk from standing: it shows ``phase0`` until ``go`` [s], then
    runs at the cycle's ``period`` [s]."""

    phase0: float
    go: float
    period: float

    def phase(self, t):
        """The phase the clock shows at t [s] (from ``go`` on)."""
        return self.phase0 + (t - self.go) / self.period

    def time(self, phase):
        """When [s] the clock shows ``phase``."""
        return self.go + (phase - self.phase0) * self.period


def _zmp(cycle, phase) -> np.ndarray:
    """The cycle's zero-moment point (x, y) [m] at ``phase``, one stride further each lap."""
    u = phase - math.floor(phase)
    p = np.array([np.interp(u, cycle.com.phase, cycle.com.zmp[:, i], period=1.0)
                  for i in range(2)])  # fmt: skip
    p[0] += cycle.stride * math.floor(phase)
    return p


def _com_piece(t, c_xy, z, side, k) -> ComPiece:
    """The planned path (x, y) and height z at the samples t, with their differences."""
    c = np.column_stack([c_xy, z])
    dc = np.gradient(c, SAMPLE, axis=0)
    ddc = np.gradient(dc, SAMPLE, axis=0)
    return ComPiece(t, c, dc, ddc, side, k)


def _striking(phase) -> tuple[str, int]:
    """(side, footstep) of the heel strike at ``phase`` (a whole or half number)."""
    side = "left" if round(2 * phase) % 2 else "right"
    return side, footstep_phase(side, phase + 0.25)[0]


def _start_piece(cycle, clk: _Clock, feet: dict, anchors: dict, c_stand: np.ndarray,
                 omega2: float) -> ComPiece:  # fmt: skip
    """The start's centre of mass, from standing still over the feet to the cycle's."""
    go, phase0 = clk.go, clk.phase0
    # the start, in the right footstep 0's frame: from standing still to the steady cycle at
    # the right foot's second heel strike (the first step's landing was too soon: the centre
    # of mass had to reach the cycle's speed from rest in a step, 5.6 m/s^2, and the body fell)
    t_land = clk.time(MERGE)
    t = np.arange(0.0, t_land + 0.5 * SAMPLE, SAMPLE)
    t[-1] = t_land
    middle = 0.5 * (feet["left"] + feet["right"]) - anchors["right"][:2]
    p = np.array([
        middle + float(smooth_step((ti - 0.1) / (go - 0.1))) * (_zmp(cycle, phase0) - middle)
        if ti < go else _zmp(cycle, clk.phase(ti))
        for ti in t
    ])  # fmt: skip
    c_end, dc_end, _ = cycle.com.at(MERGE)
    c0 = c_stand[:2] - anchors["right"][:2]
    xy = pendulum_path(p, omega2, SAMPLE, (c0, np.zeros(2)), (c_end[:2], dc_end[:2]))
    w = smooth_step(t / t_land)
    z = (1 - w) * c_stand[2] + w * np.array(
        [cycle.com.at(max(clk.phase(ti), phase0))[0][2] for ti in t]
    )
    return _com_piece(t, xy, z, "right", 0)


class _Stop:
    """The stop's footsteps and supports, and its centre of mass planned over them.

    The braking foot B lands at the (steps-1)-th heel strike, the closing foot C (the other)
    beside it at the steps-th; planned in B's frame from the step before B's landing (the body
    starts braking over the foot before).
    """

    def __init__(self, h, cycle, clk: _Clock, steps: int, rest: float) -> None:
        self.cycle, self.clk = cycle, clk
        self.flat, T = cycle.gait["opposite_foot_off"], cycle.period
        flat = self.flat
        strike = [0.5 * (i + 1) for i in range(steps)]  # the heel strikes' phases (left first)
        p_b = strike[-2]
        (b_side, k_b), (c_side, k_c) = _striking(p_b), _striking(strike[-1])
        self.brake, self.closing = (b_side, k_b), (c_side, k_c)
        self.t_stop = clk.time(strike[-1] + flat)
        self.t_end = self.t_stop + rest
        self.t_from = clk.time(p_b - BRAKE + flat)  # braking starts at a double support's end
        t = np.arange(self.t_from, self.t_end + 0.5 * SAMPLE, SAMPLE)
        t[-1] = self.t_end
        self.t = t
        # the braking steps (those landing after the plan leaves the cycle, B the last), each
        # moved back by how far the braking body is behind the cycle's at its heel strike (a
        # full step, and the leg did not reach the floor: the foot hovered 2 cm up for 0.2 s,
        # the trailing toe bounced); C lands beside B
        self.middle = {sd: float(np.mean(h.sole_points(sd)[:, 0])) for sd in SIDES}
        self.step0 = step0 = {sd: _footstep(cycle, sd) for sd in SIDES}
        self.x_b0, self.y_b = step0[b_side] + [cycle.stride * k_b, 0.0]
        self.x_c, self.y_c = step0[c_side] + [cycle.stride * k_c, 0.0]
        self.t_land_b, self.t_land_c = clk.time(p_b), clk.time(strike[-1])
        self.flat_from = self.t_land_b + flat * T  # the braking foot flat
        self.edges = {sd: (float(h.sole_points(sd)[:, 0].min()),
                           float(h.sole_points(sd)[:, 0].max())) for sd in SIDES}  # fmt: skip
        # (side, footstep) -> its landing phase
        self.braking = {_striking(ph): ph for ph in strike[:-1] if ph > clk.phase(self.t_from)}
        # (it does not depend on how far steps move back)
        self.bearing = [self.stance(ti) for ti in t]

    def footstep(self, sd, k, back) -> float:
        """The x of a side's footstep k, the braking ones moved back by ``back`` [m]."""
        (b_side, k_b), (c_side, k_c) = self.brake, self.closing
        x = self.step0[sd][0] + self.cycle.stride * k
        if (sd, k) == (c_side, k_c):
            return x - (self.x_c - self.x_b0) - back[(b_side, k_b)]
        return x - back.get((sd, k), 0.0)

    def stance(self, ti) -> dict:
        """Each bearing side's (footstep, contact kind) at ti, as the controller has them
        (the heel from heel strike, the sole from foot flat, the toe from heel off; the
        braking foot flat once flat, both feet flat once stopped)."""
        phase = self.clk.phase(min(ti, self.t_stop))
        b_side, k_b = self.brake
        out = {}
        for sd in SIDES:
            k, psi = footstep_phase(sd, phase)
            kind = contact_kind(self.cycle.gait, psi)
            if sd == b_side and ti >= self.flat_from:  # the braking foot stays flat
                k, kind = k_b, 2
            if ti >= self.t_stop:
                kind = 2
            if kind:
                out[sd] = (k, kind, psi)
        return out

    def support_x(self, on, back) -> tuple[float, float]:
        """The x range [m] the loaded parts of the soles ``on`` (a :meth:`stance`) span, in the
        cycle's frame, less MARGIN each end."""
        spans = []
        for sd, (k, kind, _) in on.items():
            x = self.footstep(sd, k, back)
            heel, toe = x + self.edges[sd][0], x + self.edges[sd][1]
            quarter = 0.25 * (toe - heel)
            spans.append({1: (heel, heel + quarter), 2: (heel, toe), 3: (toe - quarter, toe)}[kind])
        return min(a for a, _ in spans) + MARGIN, max(b for _, b in spans) - MARGIN

    def lead_back(self, on, back) -> float:
        """How far the footstep that landed last among ``on`` (a :meth:`stance`) is moved
        back [m]."""
        sd = min(on, key=lambda x: on[x][2])
        return back.get((sd, on[sd][0]), 0.0)

    def path(self, omega2: float) -> tuple[np.ndarray, dict]:
        """The stop's centre of mass path (n, 2) [m], and how far each braking step is moved
        back [m]: where the body meets it as in the cycle."""
        cycle, clk, t, bearing = self.cycle, self.clk, self.t, self.bearing
        b_side, k_b = self.brake
        c_side = self.closing[0]
        c_a, dc_a, _ = cycle.com.at(clk.phase(self.t_from))
        back = dict.fromkeys(self.braking, 0.0)
        for _ in range(SHORTEN_ITERATIONS):  # each braking step where the body meets it as in
            # the cycle (a fixed point: for B, 6.5 cm, then 9.7, 11.3, ... 12.7 for the male)
            x_b = self.footstep(b_side, k_b, back)
            on_b = np.array([x_b + self.middle[b_side], self.y_b])
            rest_point = np.array([x_b + 0.5 * (self.middle[b_side] + self.middle[c_side]),
                                   0.5 * (self.y_b + self.y_c)])  # fmt: skip
            p = []
            for ti, on in zip(t, bearing, strict=True):
                if ti < self.flat_from:
                    p.append(_zmp(cycle, clk.phase(ti)) - [self.lead_back(on, back), 0.0])
                else:
                    u = (float(smooth_step((ti - self.t_land_c) / (self.flat * cycle.period)))
                         if ti > self.t_land_c else 0.0)  # fmt: skip
                    p.append(on_b + u * (rest_point - on_b))
            lo = np.full((len(t), 2), -np.inf)
            hi = np.full((len(t), 2), np.inf)
            for i, on in enumerate(bearing):
                lo[i, 0], hi[i, 0] = self.support_x(on, back)
            xy = pendulum_path(np.array(p), omega2, SAMPLE, (c_a[:2], dc_a[:2]),
                               (rest_point, np.zeros(2)), bounds=(lo, hi),
                               smooth=SMOOTH)  # fmt: skip
            before = dict(back)
            behind = 0.0
            for key, ph in sorted(self.braking.items(), key=lambda kv: kv[1]):
                lag = cycle.com.at(ph)[0][0] - np.interp(clk.time(ph), t, xy[:, 0])
                behind = max(behind, float(lag))  # never a step longer than the one before's
                back[key] = behind
            if max(abs(back[key] - before[key]) for key in back) < 1e-3:
                break
        return xy, back

    def piece(self, xy: np.ndarray, back: dict, z_stand: float) -> tuple[ComPiece, dict]:
        """The stop's :class:`ComPiece` on the path ``xy``, rising to the standing height
        ``z_stand`` [m], and each footstep's own share of its move back [m]."""
        cycle, clk, t = self.cycle, self.clk, self.t
        t_lean = self.t_land_c
        w = smooth_step((t - t_lean) / (self.t_stop + LEAN - t_lean))
        # the height the cycle has where the centre of mass is (relative to the footsteps),
        # not when: a braking body is behind the cycle's, and at the cycle's height for the
        # instant the stance leg could not reach the floor (the foot hovered, toes up, its
        # heel loaded)
        grid = np.linspace(clk.phase(self.t_from) - 0.5, clk.phase(self.t_end) + 0.5, 2000)
        x_grid, z_grid = np.array([cycle.com.at(ph)[0][[0, 2]] for ph in grid]).T
        x_eff = xy[:, 0] + np.array([self.lead_back(on, back) for on in self.bearing])
        z_cyc = np.interp(x_eff, x_grid, z_grid)
        z = (1 - w) * z_cyc + w * z_stand
        # the controller moves each footstep back by its own share (the anchors chain)
        order = sorted(self.braking.items(), key=lambda kv: kv[1])
        moved = {key: back[key] - (back[order[i - 1][0]] if i else 0.0)
                 for i, (key, _) in enumerate(order)}  # fmt: skip
        moved[self.closing] = float(self.x_c - self.x_b0)
        return _com_piece(t, xy, z, *self.brake), moved


def start_stop(h, cycle, steps: int, go: float = GO, rest: float = REST) -> StartStop:
    """The start and stop of a ``steps``-step walk of ``h`` on its fitted ``cycle`` (see the
    module docstring): the left foot steps first; the ``steps``-th heel strike is the closing
    foot's, beside the braking one."""
    if steps < 3:
        raise WalkError(f"a walk from standing to standing needs at least 3 steps, got {steps}")
    model = h.model
    data = model.createData()
    g = cycle.gait
    T = cycle.period
    off = g["foot_off"]
    q0 = h.reference_configuration()
    pin.framesForwardKinematics(model, data, q0)
    c_stand = pin.centerOfMass(model, data, q0)
    anchors = {}
    feet = {}
    for s in SIDES:
        p = data.oMf[h.sole_id(s)].translation
        nominal = _footstep(cycle, s)
        anchors[s] = np.array([*(p[:2] - nominal), 0.0])
        feet[s] = p[:2]
    phase0 = off - 0.5  # the left foot's foot off: the right foot flat, the left to swing
    z_mean = float(np.mean(cycle.com.c[:, 2]))
    omega2 = float(np.linalg.norm(model.gravity.linear)) / z_mean
    clk = _Clock(phase0, go, T)
    start = _start_piece(cycle, clk, feet, anchors, c_stand, omega2)
    plan = _Stop(h, cycle, clk, steps, rest)
    xy, back = plan.path(omega2)
    stop, moved = plan.piece(xy, back, c_stand[2])
    return StartStop(
        q0=q0, phase0=phase0, t_go=go, t_stop=plan.t_stop, t_end=plan.t_end, anchors=anchors,
        brake=plan.brake, closing=plan.closing, moved=moved,
        start=start, stop=stop,
        steps=steps, period=T, stop_from=plan.flat_from,
        lean_from=plan.t_land_c,
    )  # fmt: skip
