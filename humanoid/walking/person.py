"""A person's walk: the optimised gait cycle tracked in closed loop on the rigid ground.

The reference is a :class:`~humanoid.optimal.gait.GaitSolution`: one half stride optimised
through the body's own rigid contact dynamics (:mod:`humanoid.optimal.gait`), mirrored into a
whole stride. Its joint trajectories, its contact schedule and its contact forces are the feed
forward; the plant is the ground of :mod:`humanoid.constraints.ground` (every foot corner a
unilateral Coulomb contact) with the joint ranges in the same solve. A task-space
inverse-dynamics QP (:func:`~humanoid.control.qp.contact_qp`) finds the accelerations and the
forces of the loaded points, and only the joint torques leave it; the free flyer is never
actuated and nothing is placed kinematically. The QP runs every :data:`CONTROL_PERIOD`, and at
once whenever a foot starts or stops carrying load in the plant, a loaded point slides or a
velocity strays from the QP's plan; in between, the joints get the torques of its accelerations
and forces at the state now (:class:`Sampled`).

- **Contacts.** A foot corner within ``touch`` of the floor is loaded when the cycle has the
  contact point there (the nearest of the cycle's points on that foot) in its phase's contact
  set; its force is bounded above by the cycle's force at that point plus a margin that ramps
  to zero over ``ramp`` before the cycle lifts it, so a point is unloaded before it leaves.
- **Costs.** The cycle's forces (per point, in body weights), the joints' trajectories, the
  pelvis's orientation, the centre of mass and the swing foot's pose, each a PD law around the
  cycle's acceleration; on a circle, a stance foot on its heel (or forefoot) where the cycle
  has it flat is turned flat.
- **Footsteps.** The swing foot lands where the cycle has it, moved by the capture point's
  error (``placement``) and by the centre of mass's position error (``position``): with the
  capture point's alone, an error of the centre of mass's position is carried from step to
  step, never corrected (on a 2 m circle at the straight cycle's speed the feet landed 4 mm
  further out each step, 12 cm after eight, and the body fell; with ``position`` at 1 both
  bodies walk it). At each heel strike the reference moves (blended) to where the foot
  landed; on a circle only along the direction of travel, so that the circle keeps its centre.

The same tracker walks from standing and stops standing (:func:`walk_from_standing`: a start
and a stop optimised into and out of the cycle, :mod:`humanoid.optimal.transitions`) and along
a circle (:func:`walk_cycle`'s ``radius``: a whole stride optimised along it,
:mod:`humanoid.optimal.turn`): each is a reference of the same kind, its forces and contacts
the optimum's.
"""

from __future__ import annotations

import bisect
import math
import time
from dataclasses import dataclass

import numpy as np
import pinocchio as pin

from ..control.qp import (
    JointWrenches,
    WarmQP,
    checked,
    contact_qp,
    dynamics_terms,
    feet_contacts,
    point_drifts,
    ramped_bound,
)
from ..control.tasks import (
    CentreOfMassTask,
    ForceTask,
    FrameTask,
    OrientationTask,
    PostureTask,
    TaskStack,
)
from ..effects import Effect
from ..errors import WalkError
from ..model import SIDES
from ..optimal.cycle import (
    KINDS,
    TurnSolution,
    check_radius,
    rotation,
    stored_transition,
    stored_turn,
)  # fmt: skip
from .gait import FALL_HEIGHT, PHASE0, GaitRecorder, GroundWalk

__all__ = [
    "CONTROL_PERIOD",
    "OFF_COURSE",
    "SLIDING",
    "CycleGains",
    "CycleReference",
    "CycleTracker",
    "Sampled",
    "walk_cycle",
    "walk_from_standing",
]

LWA = pin.ReferenceFrame.LOCAL_WORLD_ALIGNED
MATCH = 0.01  # [m] a detected corner is the cycle's contact point this near, on the same body
# [s] the QP's period: the male body's 10 steps had the same gait to 1-2 % with the QP at every
# step and every 4 ms, at 0.44 and 0.74 times real time (humanoid bench walk); every 8 ms its
# stances slid 1.3 mm (0.25 at 4 ms)
CONTROL_PERIOD = 4e-3
SLIDING = 0.01  # [m/s] a loaded point this fast slides: the QP is solved at once
OFF_COURSE = 0.5  # [m/s, rad/s] a velocity this far from the held accelerations': solved at once
TABLE_STEP = 1e-3  # [s] the tracker's reference is tabulated this finely (CycleReference.tabulated)


@dataclass(frozen=True)
class CycleGains:
    """Gains [1/s^2 for kp, 1/s for kd] and weights of the cycle tracker's QP."""

    joint_kp: float = 400.0
    joint_kd: float = 40.0
    com_kp: float = 100.0
    com_kd: float = 20.0
    pelvis_kp: float = 400.0
    pelvis_kd: float = 40.0
    foot_kp: float = 900.0
    foot_kd: float = 60.0
    w_joint: float = 0.01  # the joints follow the cycle in the null space of the rest
    # (at 30 the male's and the female's turns of objective revision 3 fell at 3.6 and 3.3 s: the
    # swing foot, traded for the centre of mass, landed rolled 19 degrees on its outer heel)
    w_com: float = 10.0
    w_pelvis: float = 10.0
    w_foot: float = 10.0
    # per (body weight)^2 from the cycle's force (at 1 the male's turn's ankle moment peaked at
    # 1.65 N m/kg, above the adults' 1.6; at 5, 1.55, the straight walks within 0.02 of before)
    w_force: float = 5.0
    margin: float = 0.5  # [body weights] a loaded point's force may exceed the cycle's by this
    ramp: float = 0.03  # [s] ... the margin fading to zero before the cycle lifts the point
    mu: float = 0.8
    touch: float = 5e-3  # [m] a corner this close to the floor may carry load
    placement: float = 1.0  # the capture point's error's share moved into the swing foot's landing
    position: float = 1.0  # ... and the centre of mass's position error's (see the module)
    max_shift: float = 0.15  # [m]
    blend: float = 0.15  # [s] a new footstep's offset enters the reference over this time
    range_margin: float = -1.0  # [rad] joint-range dampers within this of a limit (< 0: none:
    # the cycle keeps 0.05 rad inside the ranges, and the plant enforces them)
    range_time: float = 0.05  # [s]
    phase_time: float = 0.1  # [s] the cycle's clock closes the centre of mass's lead or lag in
    # this time (0: the clock is real time)
    settle: float = 0.02
    contact_time: float = 0.02
    horizon: float = 0.02


class CycleReference:
    """An optimised cycle (:class:`~humanoid.optimal.gait.GaitSolution`) as functions of time.

    Within each collocation interval x is the cubic through the nodes' x and v (so v is
    continuous and a piecewise linear, as trapezoidal collocation has it); forces are
    interpolated linearly. Lap n of the stride is the first moved 2 n steps forward.
    :meth:`through` builds the motion of a start from standing, whole strides and a stop (not
    periodic: after its end, the last state).
    """

    periodic = True

    def __init__(self, gait) -> None:
        self.gait, self.om = gait, gait.om
        self.t, self.x, self.v, self.forces = gait.stride()
        self.period = float(self.t[-1])
        self.stride = 2.0 * gait.step_length
        self.sets = gait.contact_sets()
        # a stride along a circle (:class:`~humanoid.optimal.cycle.TurnSolution`) laps turned
        self.turn = gait.turn if isinstance(gait, TurnSolution) else None
        # [s] the steady walk: a gait lab's cycles are taken within it
        self.steady = (self.period, math.inf)

    @classmethod
    def through(cls, gait, start, stop, strides: int) -> CycleReference:
        """A start (:func:`~humanoid.optimal.transitions.optimise_start`), ``strides`` whole
        strides of ``gait`` and a stop, one after the other: each segment's first node is the
        previous one's last (where a transition meets the cycle, its own state)."""
        if strides < 1:
            raise WalkError(f"a walk from standing needs a whole stride, got {strides}")
        if isinstance(gait, TurnSolution):
            raise WalkError("a walk from standing starts and stops a straight cycle")
        ref = cls(gait)
        cycle = (ref.t, ref.x, ref.v, ref.forces, ref.sets)
        steady_from = float(start.solution.t[-1])
        # the start meets the cycle at its left heel strike, half a stride in: the stride's
        # second half first, moved to where the start ends
        h = len(gait.solution.t) - 1
        s = start.solution
        shift = start.join - gait.step_length
        half = (ref.t[h:], ref.x[h:], ref.v[h:], {p: f[h:] for p, f in ref.forces.items()},
                ref.sets[h:], shift)  # fmt: skip
        segments = [(s.t, s.x, s.v, s.forces, start.contact_sets(), 0.0), half]
        shift += ref.stride
        for _ in range(strides):
            segments.append((*cycle, shift))
            shift += ref.stride
        s = stop.solution
        segments.append((s.t, s.x, s.v, s.forces, stop.contact_sets(), shift))
        steady_until = steady_from + (strides + 0.5) * ref.period
        names = sorted({p for seg in segments for p in seg[3]})
        t, x, v, sets = [0.0], [segments[0][1][0]], [segments[0][2][0]], []
        forces = {p: [segments[0][3].get(p, np.zeros((1, 3)))[0]] for p in names}
        for ts, xs, vs, fs, ss, dx in segments:
            t += list(t[-1] + ts[1:] - ts[0])
            xs = xs[1:].copy()
            xs[:, 0] += dx
            x += list(xs)
            v += list(vs[1:])
            for p in names:
                forces[p] += list(fs[p][1:] if p in fs else np.zeros((len(ts) - 1, 3)))
            sets += list(ss)
        ref.t, ref.x, ref.v = np.array(t), np.array(x), np.array(v)
        ref.forces = {p: np.array(f) for p, f in forces.items()}
        ref.sets = sets
        # (a heel strike's event, from the force, lands within a few % of the cycle's)
        slack = 0.05 * ref.period
        ref.steady = (steady_from - slack, steady_until + slack)
        ref.periodic = False
        ref.period = float(ref.t[-1])
        ref.stride = 0.0
        return ref

    def _interval(self, t: float) -> tuple[int, int, float]:
        if self.periodic:
            lap = math.floor(t / self.period)
            tau = t - lap * self.period
        else:
            lap, tau = 0, min(max(t, 0.0), self.period)
        times = self._times()
        # (np.searchsorted(t, tau, side="right") - 1, clipped to the intervals)
        k = min(max(bisect.bisect_right(times, tau) - 1, 0), len(times) - 2)
        return lap, k, tau - self.t[k]

    def _times(self) -> list[float]:
        """The nodes' times as a list (bisect on it), made again when ``t`` is replaced."""
        cached = getattr(self, "_t_list", None)
        if cached is None or cached[0] is not self.t:
            cached = self._t_list = (self.t, self.t.tolist())
        return cached[1]

    def coordinates(self, t: float):
        """(x, v, a) of the OCP model at t."""
        lap, k, s = self._interval(t)
        h = self.t[k + 1] - self.t[k]
        x0, x1, v0, v1 = self.x[k], self.x[k + 1], self.v[k], self.v[k + 1]
        u = s / h
        h00, h10 = 2 * u**3 - 3 * u**2 + 1, u**3 - 2 * u**2 + u
        h01, h11 = -2 * u**3 + 3 * u**2, u**3 - u**2
        d00, d10, d01, d11 = (
            6 * u**2 - 6 * u,
            3 * u**2 - 4 * u + 1,
            -6 * u**2 + 6 * u,
            3 * u**2 - 2 * u,
        )
        e00, e10, e01, e11 = 12 * u - 6, 6 * u - 4, -12 * u + 6, 6 * u - 2
        x = h00 * x0 + h10 * h * v0 + h01 * x1 + h11 * h * v1
        v = (d00 * x0 + d10 * h * v0 + d01 * x1 + d11 * h * v1) / h
        a = (e00 * x0 + e10 * h * v0 + e01 * x1 + e11 * h * v1) / h**2
        if self.turn is not None:
            return self.gait.lapped(x, v, a, lap)
        x = x.copy()
        x[0] += lap * self.stride
        return x, v, a

    def _coordinates_at(self, times: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """(x, v) of :meth:`coordinates` at many times at once, (n, nx) each (the same
        numbers)."""
        if self.periodic:
            laps = np.floor(times / self.period)
            tau = times - laps * self.period
        else:
            laps, tau = np.zeros(len(times)), np.clip(times, 0.0, self.period)
        k = np.clip(np.searchsorted(self.t, tau, side="right") - 1, 0, len(self.t) - 2)
        h = (self.t[k + 1] - self.t[k])[:, None]
        u = ((tau - self.t[k]) / h[:, 0])[:, None]
        x0, x1, v0, v1 = self.x[k], self.x[k + 1], self.v[k], self.v[k + 1]
        x = ((2 * u**3 - 3 * u**2 + 1) * x0 + (u**3 - 2 * u**2 + u) * h * v0
             + (-2 * u**3 + 3 * u**2) * x1 + (u**3 - u**2) * h * v1)  # fmt: skip
        v = ((6 * u**2 - 6 * u) * x0 + (3 * u**2 - 4 * u + 1) * h * v0
             + (-6 * u**2 + 6 * u) * x1 + (3 * u**2 - 2 * u) * h * v1) / h  # fmt: skip
        if self.turn is None:
            x[:, 0] += laps * self.stride
            return x, v
        for i in np.flatnonzero(laps).tolist():  # (a turned lap: the rows beyond the cycle)
            x[i], v[i], _ = self.gait.lapped(x[i], v[i], v[i], int(laps[i]))
        return x, v

    def state(self, t: float, h: float = 1e-3):
        """(q, v, a) of the body at t (a by central differences of v)."""
        xs, vs = zip(*(self.coordinates(s)[:2] for s in (t, t - h, t + h)), strict=True)
        q, vb = self.om.to_body(np.array(xs), np.array(vs))  # the three at once
        return q[0], vb[0], (vb[2] - vb[1]) / (2 * h)

    def tabulated(self, t: float):
        """:meth:`state` from a table of it (:meth:`_table`: at the nodes and at least every
        :data:`TABLE_STEP`, its difference step), made at the first call: at the table's times
        the same numbers; between two, the configuration's geodesic (``pin.interpolate``) and
        the rates' straight line (the male body's cycle, straight and on a 2 m circle: within
        4.4e-5 rad of :meth:`state`'s configuration, 1.1e-4 rad/s of its velocities; its
        accelerations, central differences across a node's kink within a step of one, within
        4.5 rad/s^2). The tracker reads its reference here at every QP tick: the map from the
        cycle's coordinates to the body's costs 20-30 times the lookup."""
        times, T, Q, V, A = self._table()
        if self.periodic:
            lap = math.floor(t / self.period)
            tau = t - lap * self.period
        else:
            lap, tau = 0, min(max(t, T[0]), T[-1])
        k = min(max(bisect.bisect_right(times, tau) - 1, 0), len(times) - 2)
        u = (tau - T[k]) / (T[k + 1] - T[k])
        q = pin.interpolate(self.om.body.model, Q[k], Q[k + 1], u)
        v = V[k] + u * (V[k + 1] - V[k])
        a = A[k] + u * (A[k + 1] - A[k])
        if lap:
            if self.turn is None:
                q[0] += lap * self.stride
            else:  # turned about the circle's centre: the root's place and its yaw
                theta = lap * self.turn
                c = np.array([0.0, self.gait.radius])
                q[:2] = rotation(theta) @ (q[:2] - c) + c
                turned = pin.Quaternion(math.cos(theta / 2), 0.0, 0.0, math.sin(theta / 2))
                q[3:7] = (turned * pin.Quaternion(q[3:7])).coeffs()
        return q, v, a

    def _table(self) -> tuple:
        """(times as a list, times, q, v, a): :meth:`state` at each node and at least every
        :data:`TABLE_STEP` between two (within an interval the coordinates are smooth: the
        nodes' kinks are the table's), over the cycle (lap 0) or the whole motion and two
        steps beyond each end; made again when ``t`` is replaced."""
        cached = getattr(self, "_tabled", None)
        if cached is not None and cached[0] is self.t:
            return cached[1]
        h = TABLE_STEP
        pieces = [np.linspace(a, b, max(1, math.ceil((b - a) / h - 1e-9)) + 1)[:-1]
                  for a, b in zip(self.t[:-1], self.t[1:], strict=True)]  # fmt: skip
        times = np.concatenate([*pieces, self.t[-1:]])
        if not self.periodic:  # (state holds the ends beyond them)
            times = np.concatenate([self.t[0] - h * np.array([2.0, 1.0]), times,
                                    self.t[-1] + h * np.array([1.0, 2.0])])  # fmt: skip
        xs, vs = self._coordinates_at(np.column_stack([times, times - h, times + h]).ravel())
        q, vb = self.om.to_body(xs, vs)
        table = (times.tolist(), times, q[0::3].copy(), vb[0::3].copy(),
                 (vb[2::3] - vb[1::3]) / (2 * h))  # fmt: skip
        self._tabled = (self.t, table)
        return table

    def heading(self, t: float) -> float:
        """[rad] the direction of travel at t: 0 straight on; along a circle, turning at the
        stride's steady rate (positive to the left)."""
        if self.turn is None:
            return 0.0
        lap, k, s = self._interval(t)
        return self.turn * (lap + (self.t[k] + s) / self.period)

    def force(self, t: float, point: str) -> np.ndarray:
        """[N] the cycle's force at ``point`` at t, world axes."""
        return self.forces_at(t, [point])[0]

    def forces_at(self, t: float, points) -> np.ndarray:
        """[N] the cycle's forces at ``points`` at t, (n, 3), world axes (zero at a point it
        has no force at)."""
        lap, k, s = self._interval(t)
        u = s / (self.t[k + 1] - self.t[k])
        none = ((0.0, 0.0, 0.0), (0.0, 0.0, 0.0))
        ends = np.array([(f[k], f[k + 1]) if (f := self.forces.get(p)) is not None else none
                         for p in points]).reshape(len(points), 2, 3)  # fmt: skip
        out = (1 - u) * ends[:, 0] + u * ends[:, 1]
        if self.turn is not None and lap:
            out[:, :2] = out[:, :2] @ rotation(lap * self.turn).T
        return out

    def contacts(self, t: float) -> set:
        """The cycle's points in contact at t."""
        _, k, _ = self._interval(t)
        return self.sets[k]

    def time_to_lift(self, t: float, point: str) -> float:
        """[s] until the cycle lifts ``point`` (inf if it stays down for a whole stride)."""
        lap, k, s = self._interval(t)
        j = self._lifts(point)[k]
        if j < 0:
            return math.inf
        lapj, kj = divmod(k + j, len(self.sets))
        return (lap + lapj) * self.period + self.t[kj] - t

    def _lifts(self, point: str) -> list[int]:
        """For each interval k, how many intervals on the cycle first leaves ``point`` out of
        its contacts (-1: not within a stride, or before the motion's end); made once per
        point, again when ``sets`` is replaced."""
        if getattr(self, "_lifted", (None,))[0] is not self.sets:
            self._lifted: tuple[list, dict[str, list[int]]] = (self.sets, {})
        tables, n = self._lifted[1], len(self.sets)
        if point not in tables:
            tables[point] = [next((j for j in range(n if self.periodic else n - k)
                                   if point not in self.sets[(k + j) % n]), -1)
                             for k in range(n)]  # fmt: skip
        return tables[point]


class Sampled:
    """The person's controller between its QP's ticks (see :meth:`CycleTracker.before_step`):
    the torques of the last solve's accelerations and contact forces at the state now, and
    what tells that the QP must run again (a foot landing or lifting, a loaded point sliding,
    a velocity off the held accelerations' course).

    Args:
        model: The plant's model.
        side_of_joint: The side of each joint of the feet.
    """

    def __init__(self, model, side_of_joint: dict) -> None:
        self.model, self.side_of_joint = model, side_of_joint
        self.every = 1  # the QP every this many steps (and when before_step says so)
        self.solves = 0  # QP solves so far
        self.solved_with: frozenset | None = None  # the loaded feet at the last solve
        self.data = model.createData()  # the held torques' (their RNEA's state: sliding)
        self._wrenches = JointWrenches(model)  # the held forces' wrenches on the joints
        self._held: tuple | None = None  # (dv, wrenches) of the last solve
        self._course: tuple | None = None  # (v, dv) of the last solve
        self.held_for = 0  # steps held since the last solve

    def hold(self, v, dv, joints, local, f, data) -> None:
        """Hold a solve's accelerations ``dv`` (from the velocities ``v`` of its tick) and its
        forces ``f`` (world axes) at points ``local`` of ``joints`` (in their frames; ``data``:
        the kinematics at the tick), as wrenches on the joints, in their frames about their
        origins."""
        self._held = (dv, self._wrenches.set(data, joints, local, f))
        self._course = (np.array(v), dv)
        self.held_for = 0  # steps since the tick

    def off_course(self, v, dt: float) -> bool:
        """Whether a velocity is more than ``OFF_COURSE`` from where the held accelerations
        take the tick's: the plant did what the QP did not plan (a joint stopped by its range,
        a foot's corner struck), and it must plan again."""
        assert self._course is not None, "off_course before the first solve"
        v0, dv = self._course
        ahead = (self.held_for + 1) * dt
        return bool(np.abs(v - v0 - ahead * dv).max() > OFF_COURSE)

    def torques(self, q, v) -> np.ndarray:
        """The torques of the held accelerations dv and forces f at the state now,
        tau = (M dv + h - J^T f) on the joints (one RNEA, f as wrenches on the loaded points'
        joints, at the points' places on their bodies): the QP's own torques at its tick, and
        following the configuration and the velocities after it (held as constants, a light
        segment's torque went stale: the female body's toes diverged on a 2 m circle at a 4 ms
        period)."""
        assert self._held is not None, "held torques before the first solve"
        dv, fext = self._held
        tau = pin.rnea(self.model, self.data, q, v, dv, fext)
        tau[:6] = 0.0
        return tau

    def sliding(self, found) -> bool:
        """Whether a point the last ground step pushed up moves faster than ``SLIDING`` now
        (its speed on its body at the state of :meth:`torques`' RNEA)."""
        if found is None or not len(found.impulses):
            return False
        pushed = found.impulses[:, 2] > 0.0
        joints, local, vj = found.joints[pushed], found.local[pushed], self.data.v
        for j in set(joints.tolist()):
            r = local[joints == j] if len(joints) > 1 else local
            # the points' velocities v + w x r (joint j's axes), as r [w]x^T + v
            velocity = r @ pin.skew(vj[j].angular).T + vj[j].linear
            if (velocity * velocity).sum(axis=1).max() > SLIDING * SLIDING:
                return True
        return False

    def loaded_feet(self, found) -> frozenset:
        """The sides whose feet the last ground step pushed up (none before the first)."""
        if found is None or not len(found.impulses):
            return frozenset()
        pushed = found.joints[found.impulses[:, 2] > 0.0].tolist()
        return frozenset(self.side_of_joint.get(j) for j in pushed) - {None}


class CycleTracker(Effect):
    """The controller (an effect of the scene: its torques): see the module."""

    name = "cycle"
    velocity_dependent = True

    def __init__(self, h, model, reference: CycleReference, ground, dt, t0: float,
                 gains: CycleGains | None = None) -> None:  # fmt: skip
        from ..constraints.limits import JointRanges

        self.h, self.model, self.ref = h, model, reference
        self.ground, self.dt, self.t0 = ground, dt, t0
        self.tc = t0  # the cycle's time
        self.t_last: float | None = None  # the last control time
        self.gains = gains or CycleGains()
        self.data = model.createData()
        self.rdata = model.createData()
        self.weight = h.mass * float(np.linalg.norm(model.gravity.linear))
        self.ranges = JointRanges(h)
        self.sole = {s: h.sole_id(s) for s in SIDES}
        self.pelvis = model.getFrameId(model.names[1], pin.FrameType.JOINT)
        # the cycle's contact points by side, and the foot joints they are on
        om = reference.om
        self.points = {s: [f.name for f in om.model.frames if f.name.startswith(s)
                           and f.name in set(reference.forces)] for s in SIDES}  # fmt: skip
        self.point_id = {p: model.getFrameId(p) for s in SIDES for p in self.points[s]}
        self.point_joint = {p: model.frames[f].parentJoint for p, f in self.point_id.items()}
        # the cycle's points of both feet: names, places in their joints' frames, joints
        names = [p for s in SIDES for p in self.points[s]]
        self._all_points = (
            names,
            np.array([model.frames[self.point_id[p]].placement.translation for p in names]),
            np.array([self.point_joint[p] for p in names], dtype=int),
        )
        self.side_of_joint = {
            j: s for s in SIDES for j in model.subtrees[model.frames[self.sole[s]].parentJoint]
        }
        self.sampled = Sampled(model, self.side_of_joint)  # between the QP's ticks
        self.tau = np.zeros(model.nv)
        self.qp = WarmQP(eps_abs=1e-9, max_iter=1000, primal=1e-7, dual=1e-4)
        self.relaxed = 0
        # the last solve: (accelerations, contact forces, the loaded points)
        self.last: tuple[np.ndarray, np.ndarray, list[int]] | None = None
        self.offset = np.zeros(2)  # the reference moved to the last footstep actually made
        self.offset_from, self.offset_to, self.offset_t = np.zeros(2), np.zeros(2), -1.0
        self.landed = dict.fromkeys(SIDES, True)
        self.heels = {s: [p for p in self.points[s] if "heel" in p] for s in SIDES}
        z = pin.centerOfMass(model, self.data, reference.state(t0)[0])[2]
        self.omega = math.sqrt(float(np.linalg.norm(model.gravity.linear)) / z)
        self.loaded_before: set[int] = set()
        # the last step's reference centre of mass: (x, y) [m], the direction of travel, and
        # the speed along it [m/s]
        self.com_ref: tuple[np.ndarray, np.ndarray, float] | None = None

    def force(self, model, data, t, q, v):
        return self.tau

    def before_step(self, sim, k: int, t: float, q, v) -> None:
        """The run loop's hook: the QP at every ``every``-th step, and at once when the set of
        feet the plant's ground carries changes (a heel strike, a toe off), a velocity is off
        the held accelerations' course or a loaded point slides; :meth:`Sampled.torques` in
        between."""
        found, held = sim.ground_step, self.sampled
        loaded = held.loaded_feet(found)
        if k % held.every and loaded == held.solved_with and not held.off_course(v, self.dt):
            tau = held.torques(q, v)
            if not held.sliding(found):
                self.tau = tau
                held.held_for += 1
                return
        self.update(t, q, v)
        held.solved_with = loaded
        held.solves += 1

    def update(self, t: float, q, v) -> np.ndarray:
        model, data, g, dt, ref = self.model, self.data, self.gains, self.dt, self.ref
        tc = self._advance_clock(t, q)
        M, hvec = dynamics_terms(model, data, q, v)
        found, _ = feet_contacts(self.ground, model, data, {}, q)
        phi, joint_of = found.phi, found.joints.tolist()
        q_r, v_r, a_r = ref.tabulated(tc)
        # the reference follows the footsteps the body makes (blended in)
        u = min(1.0, (t - self.offset_t) / g.blend) if self.offset_t >= 0 else 1.0
        self.offset = self.offset_from + smooth(u) * (self.offset_to - self.offset_from)
        q_r = q_r.copy()
        q_r[:2] += self.offset
        rd = self.rdata
        pin.forwardKinematics(model, rd, q_r, v_r, a_r)
        pin.updateFramePlacements(model, rd)
        in_contact = ref.contacts(tc)
        loaded, free, match = self._corners(joint_of, phi, found.local, in_contact)
        bearing = {self.side_of_joint.get(joint_of[i]) for i in loaded}
        self._reanchor(t, tc, match)
        tasks = TaskStack(model, data, q, v)
        tasks.add(PostureTask(q_r, g.joint_kp, g.joint_kd, g.w_joint, v_r, a_r))
        tasks.add(OrientationTask.following(model, rd, self.pelvis, g.pelvis_kp, g.pelvis_kd,
                                            g.w_pelvis))  # fmt: skip
        # centre of mass
        c_r = pin.centerOfMass(model, rd, q_r, v_r, a_r)
        dc_r, ddc_r = rd.vcom[0].copy(), rd.acom[0].copy()
        com = tasks.add(CentreOfMassTask(c_r, dc_r, ddc_r, g.com_kp, g.com_kd, g.w_com))
        c, dc = com.c, com.dc
        assert c is not None and dc is not None  # computed by tasks.add
        heading = ref.heading(tc)
        ahead = np.array([math.cos(heading), math.sin(heading)])
        self.com_ref = (c_r[:2].copy(), ahead, float(dc_r[:2] @ ahead))
        # a swing foot: its pose, its landing moved by the capture point's error and the centre
        # of mass's
        xi = c[:2] + dc[:2] / self.omega
        xi_r = c_r[:2] + dc_r[:2] / self.omega
        shift = g.placement * (xi - xi_r) + g.position * (c[:2] - c_r[:2])
        norm = np.linalg.norm(shift)
        if norm > g.max_shift:
            shift *= g.max_shift / norm
        for s in SIDES:
            if s not in bearing:
                tasks.add(FrameTask.following(model, rd, self.sole[s], g.foot_kp, g.foot_kd,
                                              g.w_foot, shift))  # fmt: skip
            elif ref.turn is not None and any(p in in_contact and p not in match
                                              for p in self.points[s]):  # fmt: skip
                # on a circle, a foot on its heel (or its forefoot) where the cycle has it flat
                # is turned flat: its loaded points alone leave it free to pitch (landing
                # behind the cycle, a turn's stance foot rose onto its heel, 14 degrees toes up
                # in 0.3 s). (Not on a straight walk: there it slid the predictive walk's
                # feet 3.8 mm, 1.0 without; kept to the pitch alone, or only past 0.01-0.05
                # rad of pitch, the turns fell)
                tasks.add(OrientationTask.following(model, rd, self.sole[s], g.foot_kp,
                                                    g.foot_kd, g.w_foot))  # fmt: skip
        # the cycle's forces: contact_qp's w_force |f|^2 becomes w_force |f - f_cycle|^2, the
        # normal forces under the cycle's plus a margin that ramps to zero before it lifts
        target, upper = self._cycle_forces(tc, match)
        p = contact_qp(model, data, self.ground, found, loaded, free, tasks, M, hvec, q, v, dt,
                       self.weight, g, self.ranges, g.range_margin, g.range_time,
                       drift=point_drifts(self.data, [joint_of[i] for i in loaded],
                                          found.local[loaded]),
                       forces=[ForceTask(target, g.w_force)],
                       upper=upper if loaded else None)  # fmt: skip
        x, relaxed = p.solve(self.qp)
        self.relaxed += relaxed
        self.tau, dv, f = p.torques(checked(x, "cycle tracker's", t, self.qp), M, hvec,
                                    self.weight)  # fmt: skip
        self.last = (dv, f, match)
        if self.sampled.every > 1:
            self.sampled.hold(v, dv, [joint_of[i] for i in loaded], found.local[loaded], f, data)
        return self.tau

    def _cycle_forces(self, tc: float, match) -> tuple[np.ndarray, np.ndarray]:
        """The loaded corners' forces from the cycle's at its time ``tc`` [body weights], each
        point's shared among the corners matched to it, and their vertical upper bounds: the
        cycle's plus a margin that fades to zero before the cycle lifts the point."""
        g, ref = self.gains, self.ref
        count: dict[str, int] = {}
        for m in match:
            count[m] = count.get(m, 0) + 1
        shares = np.array([count[m] for m in match], dtype=float)
        f_ref = ref.forces_at(tc, match) / self.weight / shares[:, None]
        lift = {m: ref.time_to_lift(tc, m) for m in count}
        upper = np.array([ramped_bound(f, lift[m], g.ramp, g.margin / count[m])
                          for f, m in zip(f_ref[:, 2].tolist(), match, strict=True)])  # fmt: skip
        return f_ref.ravel(), upper

    def _advance_clock(self, t: float, q) -> float:
        """The cycle's time at t: real time, sped up or slowed down by how far the body's
        centre of mass is ahead of the cycle's (along the direction of travel) at the last step
        (a phase variable, as hybrid zero dynamics uses one)."""
        g = self.gains
        if self.t_last is not None:
            rate = 1.0
            if g.phase_time > 0:
                c = pin.centerOfMass(self.model, self.data, q)[:2]
                assert self.com_ref is not None  # set by the update that set t_last
                c_p, ahead, dc_p = self.com_ref
                lead = float((c - c_p) @ ahead)  # along the direction of travel
                rate = float(np.clip(1.0 + lead / (max(dc_p, 0.3) * g.phase_time), 0.3, 2.0))
            self.tc += (t - self.t_last) * rate
        self.t_last = t
        return self.tc

    def _corners(self, joint_of, phi, local, in_contact):
        """The detected corners split into loaded and free (indices), and the cycle's point
        each loaded one is (see the module)."""
        g = self.gains
        loaded, free, match = [], [], []
        nearest = self._nearest(joint_of, local)
        for i, best in enumerate(nearest):
            keep = best is not None and best in self.loaded_before and phi[i] < g.touch
            if best is not None and (best in in_contact or keep) and phi[i] < g.touch:
                loaded.append(i)
                match.append(best)
            else:
                free.append(i)
        # a trailing foot the cycle has lifted stays down until the other one lands
        cycle_sides = {p.split("_")[0] for p in in_contact}
        landed = any(m.split("_")[0] in cycle_sides and m in in_contact for m in match)
        for j in range(len(loaded) - 1, -1, -1):
            side = match[j].split("_")[0]
            if match[j] in in_contact or (side not in cycle_sides and not landed):
                continue
            free.append(loaded.pop(j))
            match.pop(j)
        # a free corner of a foot that bears load is the plant's to keep out of the floor (its
        # rearfoot's corners, rolling over the toes, made the QP infeasible at every heel-off)
        bearing = {self.side_of_joint.get(joint_of[i]) for i in loaded}
        free = [i for i in free if self.side_of_joint.get(joint_of[i]) not in bearing]
        self.loaded_before = set(match)
        return loaded, free, match

    def _nearest(self, joint_of, local) -> list:
        """The cycle's point at each detected corner (``local``: in its joint's frame), or
        None: the nearest of the cycle's points on the same body, within :data:`MATCH` (on
        one body, measured in its frame)."""
        out = [None] * len(joint_of)
        names, at, joints = self._all_points
        if not len(joint_of) or not names:
            return out
        d = local[:, None, :] - at[None]
        d2 = np.where(np.asarray(joint_of)[:, None] == joints[None], (d * d).sum(axis=2), np.inf)
        k = d2.argmin(axis=1)
        for i, (ki, di) in enumerate(zip(k.tolist(), d2[np.arange(len(k)), k].tolist(),
                                         strict=True)):  # fmt: skip
            if di < MATCH * MATCH:
                out[i] = names[ki]
        return out

    def _reanchor(self, t: float, tc: float, match) -> None:
        """At a heel strike, the reference moves (over ``blend``) to where the foot landed; on
        a circle only along the direction of travel (moved sideways, the circle's centre would
        follow the feet: the body drifted outwards, 11 cm in five steps, and fell)."""
        data, rd = self.data, self.rdata
        for s in SIDES:
            heel_down = any(m in self.heels[s] for m in match)
            if heel_down and not self.landed[s]:
                actual = np.mean([data.oMf[self.point_id[p]].translation[:2]
                                  for p in self.heels[s]], axis=0)  # fmt: skip
                planned = np.mean([rd.oMf[self.point_id[p]].translation[:2]
                                   for p in self.heels[s]], axis=0)  # fmt: skip
                moved = actual - planned
                if self.ref.turn is not None:
                    heading = self.ref.heading(tc)
                    ahead = np.array([math.cos(heading), math.sin(heading)])
                    moved = (moved @ ahead) * ahead
                self.offset_from = self.offset.copy()
                self.offset_to = self.offset + moved
                self.offset_t = t
            self.landed[s] = heel_down or (self.landed[s] and any(
                m.startswith(s) for m in match))  # fmt: skip


def smooth(u: float) -> float:
    """A cubic ease from 0 to 1 over u in [0, 1]."""
    u = min(max(u, 0.0), 1.0)
    return u * u * (3 - 2 * u)


def walk_cycle(h, gait, steps: int = 20, *, dt: float = 1e-3, mu: float = 0.8, gains=None,
               phase0: float = PHASE0, quiet: bool = True, pushes=(), record_rate=100.0,
               radius: float | None = None, control_dt: float | None = None):  # fmt: skip
    """Simulate ``h`` walking ``steps`` heel strikes along the optimised ``gait`` (along a
    circle of ``radius`` [m], positive turning left, or straight on); returns a
    :class:`~humanoid.walking.gait.GroundWalk`. ``control_dt``: the QP's period [s], a whole
    number of steps (default :data:`CONTROL_PERIOD`, or every step if ``dt`` is longer)."""
    if steps < 1:
        raise WalkError(f"steps must be at least 1, got {steps}")
    if radius is not None:
        gait = _turned(gait, check_radius(radius), quiet)
    ref = CycleReference(gait)
    t0 = phase0 * ref.period
    first = (1.0 - phase0) % 0.5 or 0.5
    duration = (first + (steps - 1) / 2) * ref.period + 0.3
    return _walk(h, ref, t0, duration, steps, dt, mu, gains, quiet, pushes, record_rate, control_dt)


def walk_from_standing(h, gait, strides: int = 2, *, start=None, stop=None, dt: float = 1e-3,
                       mu: float = 0.8, gains=None, quiet: bool = True, rest: float = 1.0,
                       record_rate=100.0, control_dt: float | None = None):  # fmt: skip
    """Simulate ``h`` starting from standing, walking ``strides`` whole strides of ``gait`` and
    stopping to stand, then ``rest`` seconds standing; a
    :class:`~humanoid.walking.gait.GroundWalk` of ``2 strides + 5`` heel strikes.

    The start and the stop (:class:`~humanoid.optimal.cycle.Transition`) are ``start`` and
    ``stop`` if given, else the ones shipped or cached for this very cycle, else optimised now
    (:func:`humanoid.optimal.transitions.transition`, which needs casadi) and cached.
    ``control_dt``: as :func:`walk_cycle`'s.
    """
    ends = [start, stop]
    for i, kind in enumerate(KINDS):
        if ends[i] is None:
            ends[i] = stored_transition(gait, kind) or _optimised_transition(gait, kind, quiet)
    ref = CycleReference.through(gait, ends[0], ends[1], strides)
    return _walk(h, ref, 0.0, ref.period + rest, 2 * strides + 5, dt, mu, gains, quiet, (),
                 record_rate, control_dt)  # fmt: skip


def _optimised_transition(gait, kind: str, quiet: bool):
    def solve():
        from ..optimal.transitions import transition

        return transition(gait, kind)

    return _optimised(f"the {kind} of the {gait.speed:.2f} m/s gait cycle", quiet, solve)


def _turned(gait, radius: float, quiet: bool):
    """``gait`` along a circle of ``radius``: shipped, cached or optimised now."""

    def solve():
        from ..optimal.turn import turn

        return turn(gait, radius)

    what = f"the {gait.speed:.2f} m/s gait cycle along a {radius:g} m circle"
    return stored_turn(gait, radius) or _optimised(what, quiet, solve)


def _optimised(what: str, quiet: bool, solve):
    """``solve()`` (which imports casadi), saying so unless ``quiet``."""
    if not quiet:
        print(f"optimising {what} (once, a few minutes; cached)", flush=True)
    try:
        return solve()
    except ImportError as exc:
        raise WalkError(
            f"{what} is not shipped or cached, and optimising it needs the optimal-control "
            f"extra ({exc})"
        ) from exc


def control_steps(control_dt: float | None, dt: float) -> int:
    """Steps of ``dt`` per QP tick for a period ``control_dt`` [s] (None: the default,
    :data:`CONTROL_PERIOD`, at least one step); WalkError unless a positive whole number of
    steps."""
    if control_dt is None:
        return max(1, int(round(CONTROL_PERIOD / dt)))
    every = control_dt / dt
    if not (math.isfinite(every) and every >= 1.0 - 1e-9 and abs(every - round(every)) < 1e-6):
        raise WalkError(f"control_dt must be a whole number of steps of {dt:g} s, got "
                        f"{control_dt:g}")  # fmt: skip
    return int(round(every))


def _walk(h, ref, t0, duration, steps, dt, mu, gains, quiet, pushes, record_rate, control_dt):
    from ..scene import Effects, GroundSpec, JointLimitSpec, Scene
    from ..simulation import Simulation

    every = control_steps(control_dt, dt)

    scene = Scene(
        name="walk", body=h.source, ball_joints=h.ball_joints, duration=duration, dt=dt,
        integrator="semi_implicit_euler", record_rate=record_rate,
        effects=Effects(joint_limits=JointLimitSpec(kind="constraint"),
                        ground=GroundSpec(bodies="feet", mu=mu), pushes=tuple(pushes)),
    )  # fmt: skip
    sim = Simulation(scene, humanoid=h)
    ctl = CycleTracker(h, sim.model, ref, sim.ground, dt, t0, gains)
    ctl.sampled.every = every
    q0, v0, _ = ref.state(t0)
    z = pin.centerOfMass(sim.model, sim.model.createData(), q0)[2]
    recorder = GaitRecorder(h, sim.model, fall_height=FALL_HEIGHT * z)
    start = time.perf_counter()
    traj = sim.run(quiet=quiet, controller=ctl, monitors=[recorder], initial=(q0, v0))
    wall = time.perf_counter() - start
    traj.metadata.update({"control_period": every * dt, "qp_solves": ctl.sampled.solves})
    return GroundWalk(traj, recorder.record(h.mass, dt), ref, ctl.relaxed, wall, steps, h)
