"""A person's walk on the rigid ground, and what a gait lab measures of it.

:func:`walk_on_ground` fits the body's gait cycle (:func:`~humanoid.walking.reference.fit_cycle`)
and simulates it, tracked by the :class:`~humanoid.walking.tracking.GaitController`: joint
torques only (the free flyer is never actuated), every sole point a unilateral contact with
Coulomb friction, the joint ranges as constraints of the same velocity-level solve.

A :class:`GaitRecorder` watches every step the way a gait lab's force plates and inverse
dynamics would, but exactly: each foot's ground force and centre of pressure (the sum of its
contact impulses over the step), the joint moments and powers (inverse dynamics, RNEA, of the
step's own acceleration and ground forces: with the semi-implicit step this is the plant's own
equation of motion, not an estimate), which parts of each sole carry load (heel, toe), and how
far the loaded points slide.

:func:`analyse` turns the record into what a gait lab reports:

- **filtering**: the ground forces and the joint moments and powers are low-passed before
  anything is sampled from them, as a gait lab filters its force plates and its inverse
  dynamics: a zero-lag Butterworth (second order run forwards and backwards, fourth order in
  effect) at :data:`CUTOFF` (15 Hz), the same cut-off for forces and moments (Kristianslund,
  Krosshaug & van den Bogert 2012, J Biomech 45:666: a lower cut-off on the kinematics than
  on the forces makes spurious moment peaks). The simulation's forces are 1 ms contact
  impulses; unfiltered, a 51-sample curve picks up single ticks.
- **events**: heel strike and toe off of each foot from its unfiltered vertical force with
  hysteresis, as a force plate's event detection: a contact starts where the force rises above
  :data:`EVENT_ON` (2 % of body weight) and ends where it falls below :data:`EVENT_OFF` (1 %),
  so that chatter about one threshold does not count two touchdowns; contacts and gaps
  shorter than 50 ms are ignored;
- **spatiotemporal parameters** per cycle: speed (stride length over stride time), cadence,
  step length (along the stride), stance and double support, centre-of-mass vertical and
  lateral excursion;
- **curves** over 0-100 % of the cycle (from the side's heel strike) in the normative data's
  conventions (:mod:`humanoid.walking.norms`): joint angles (:mod:`~humanoid.walking.clinical`)
  [deg]; ground reaction forces (vertical, and fore-aft along the stride, braking negative)
  [body weights]; the arms' shoulder and elbow flexion
  (:class:`~humanoid.walking.clinical.ArmChain`) [deg]; internal joint moments [N m/kg] (hip
  extensor and abductor, knee extensor, ankle plantarflexor positive: the moment the proximal
  segment exerts on the distal one, projected on the proximal segment's axes) and joint powers
  [W/kg] (moment times the distal segment's angular velocity relative to the proximal one;
  positive is generated).
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass, field, replace
from types import SimpleNamespace
from typing import TYPE_CHECKING, Any, TypeGuard

import numpy as np
import pinocchio as pin

from ..dynamics import TreeDynamics
from ..errors import RunFailed, WalkError
from ..linalg import cross
from ..model import OTHER_SIDE as OTHER
from ..model import SIDES, lock_foot_hinges, restrict_configurations
from ..scene import Effects, GroundSpec, JointLimitSpec, PushSpec, Scene
from ..simulation import Simulation, Trajectory
from .clinical import ANGLES, arm_chains, leg_chains
from .reference import GaitCycle, fit_cycle, leg_length
from .tracking import GaitController, TrackingGains
from .transitions import start_stop

if TYPE_CHECKING:
    from ..model import Humanoid

__all__ = [
    "GaitAnalysis", "GaitRecord", "GaitRecorder", "GroundWalk", "PushTrials", "analyse",
    "ankle_joint", "clinical_kinetics", "contact_runs", "cycle_analysis", "gait_kinematics",
    "largest_push", "pelvis_push", "walk_on_ground",
]  # fmt: skip

EVENT_ON = 0.02  # [body weights] a foot's contact starts where its vertical force rises above
EVENT_OFF = 0.01  # [body weights] ... and ends where it falls below this (hysteresis)
CUTOFF = 15.0  # [Hz] the zero-lag low-pass of the ground forces, joint moments and powers
MIN_CONTACT = 0.05  # [s] shorter contacts and gaps are ignored (bounces, not steps)
POINT_LOAD = 1.0  # [N] a contact point with more vertical force carries load
# a step without ground contacts, as a StepContacts has them
_NO_STEP = SimpleNamespace(points=np.zeros((0, 3)), joints=np.zeros(0, dtype=int),
                           local=np.zeros((0, 3)), impulses=np.zeros((0, 3)))  # fmt: skip
FALL_HEIGHT = 0.7  # a fall: the centre of mass below this fraction of its height in the cycle
PERCENT = np.linspace(0.0, 100.0, 51)  # the normative data's samples of the cycle
KINETICS = (
    "grf_vertical", "grf_anterior", "hip_extension_moment", "hip_abduction_moment",
    "knee_extension_moment", "ankle_plantarflexion_moment", "hip_power", "knee_power",
    "ankle_power",
)  # fmt: skip
_MOMENTS = KINETICS[2:]
ARM_ANGLES = ("shoulder_flexion", "elbow_flexion")  # see clinical.ArmChain
# the curves the summary measures against the norms' mean +- 2 SD band (GaitAnalysis.in_band)
BAND_CURVES = (
    "hip_flexion", "knee_flexion", "ankle_dorsiflexion", "hip_extension_moment",
    "knee_extension_moment", "ankle_plantarflexion_moment",
)  # fmt: skip
PHASE0 = 0.2  # the walk starts at this phase of the cycle (the right foot in stance)
MID_STANCE = 0.25  # [cycle] mid-stance: between the other foot's toe off and this one's heel off
DIRECTIONS = {"forward": (1.0, 0.0), "backward": (-1.0, 0.0), "left": (0.0, 1.0),
              "right": (0.0, -1.0)}  # fmt: skip
EVERY = 10  # kinematic samples (angles, centre of mass) every this many steps


def ankle_joint(h, chain) -> int:
    """The ankle of a leg's :class:`~humanoid.walking.clinical.LegChain`: the first joint below
    its knee (WalkError if there is none)."""
    below = chain.joints[chain.joints.index(chain.knee) + 1 :]
    if not below:
        raise WalkError(f"{h.source}: the {chain.side} leg has no ankle below its knee")
    return below[0]


def clinical_kinetics(chain, ankle: int, foot: int, rotation, moment, velocity) -> np.ndarray:
    """One leg's moments [N m] and powers [W] of :data:`_MOMENTS` (hip extensor, hip abductor,
    knee extensor, ankle plantarflexor; hip, knee, ankle power) as a gait lab signs them (see
    the module docstring), from ``rotation(j)``: joint ``j``'s world rotation (its body's
    axes), ``moment(j)``: its moment on its body (the proximal segment's on the distal one)
    [N m] and ``velocity(j)``: its body's angular velocity [rad/s], both in world axes. One
    instant ((3, 3) and (3,) each; returns (7,)) or many at once ((n, 3, 3) and (n, 3);
    (n, 7)). ``ankle``: :func:`ankle_joint`; ``foot``: the joint the sole hangs from."""
    pelvis = rotation(1)
    thigh = rotation(chain.thigh) @ chain.knee_placement
    shank = rotation(chain.knee)
    p0, t0, s0, _ = chain.zero
    x_p, y_p = pelvis @ p0[0], pelvis @ p0[1]
    y_t, y_s = thigh @ t0[1], shank @ s0[1]
    sign = 1.0 if chain.side == "right" else -1.0
    hip, knee = chain.joints[0], chain.knee
    m_hip, m_knee, m_ankle = moment(hip), moment(knee), moment(ankle)
    w_pelvis, w_thigh, w_shank = velocity(1), velocity(chain.thigh), velocity(knee)
    w_foot = velocity(foot)
    return np.stack([
        _dot(m_hip, y_p), -sign * _dot(m_hip, x_p), -_dot(m_knee, y_t), _dot(m_ankle, y_s),
        _dot(m_hip, w_thigh - w_pelvis), _dot(m_knee, w_shank - w_thigh),
        _dot(m_ankle, w_foot - w_shank),
    ], axis=-1)  # fmt: skip


def _sums(x: np.ndarray, at: np.ndarray, n: int) -> np.ndarray:
    """The rows of ``x`` (k, c) summed by their step ``at`` (k,): (n, c)."""
    out = np.zeros((n, x.shape[1]))
    for c in range(x.shape[1]):
        out[:, c] = np.bincount(at, weights=x[:, c], minlength=n)
    return out


def _dot(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Dot products over the last axis."""
    return (a * b).sum(axis=-1)


@dataclass
class GaitRecord:
    """What :class:`GaitRecorder` saw, one row per simulation step.

    Attributes:
        t: (N,) times [s]. q, v: (N, nq), (N, nv) the state at the start of each step.
        force: per side, (N, 3) the ground's force on the foot, world axes [N].
        cop: per side, (N, 2) its centre of pressure on the floor [m] (NaN when unloaded).
        heel, toe: per side, (N,) whether the rear / front half of the sole carries load.
        slip: per side, (N, 2) how far the loaded points moved along the floor in the step
            (their force-weighted mean) [m].
        kinetics: per side, (N, 7) the moments [N m] and powers [W] of :data:`_MOMENTS`.
        mass: the body's mass [kg]; dt: the step [s].
    """

    t: np.ndarray
    q: np.ndarray
    v: np.ndarray
    force: dict
    cop: dict
    heel: dict
    toe: dict
    slip: dict
    kinetics: dict
    mass: float
    dt: float


class GaitRecorder:
    """A simulation monitor: ground forces, load on heel and toe, slip, joint moments and
    powers at every step (see the module docstring); raises RunFailed at a fall.

    During the run it keeps each step's states and contacts (and watches for the fall);
    :meth:`record` measures them all at once.
    """

    def __init__(self, h, model: pin.Model, fall_height: float | None = None) -> None:
        self.h, self.model = h, model
        self.data = model.createData()
        self.next = model.createData()
        self.chains = leg_chains(h)
        self.sole = {s: h.sole_id(s) for s in SIDES}
        self.foot = {s: model.frames[self.sole[s]].parentJoint for s in SIDES}
        self.middle = {s: float(np.mean(h.sole_points(s)[:, 0])) for s in SIDES}
        self.ankle = {s: ankle_joint(h, chain) for s, chain in self.chains.items()}
        # the side of every joint at or below a hip (-1: none)
        self.side_of = np.full(model.njoints, -1)
        for j in range(1, model.njoints):
            i = j
            while i > 0 and not any(i in c.joints for c in self.chains.values()):
                i = model.parents[i]
            for k, c in enumerate(self.chains[s] for s in SIDES):
                if i in c.joints:
                    self.side_of[j] = k
        # the joints whose moments, angular velocities and rotations the kinetics read
        self._moments = sorted({j for s, c in self.chains.items()
                                for j in (c.joints[0], c.knee, self.ankle[s])})  # fmt: skip
        self._omegas = sorted({1} | {j for s, c in self.chains.items()
                                     for j in (c.thigh, c.knee, self.foot[s])})  # fmt: skip
        self._rotations = sorted(set(self._moments) | set(self._omegas))
        # below[j, i]: joint i is joint j's or in its subtree (a ground force on i loads j)
        self._below = np.zeros((model.njoints, model.njoints), dtype=bool)
        for j in self._moments:
            self._below[j, list(model.subtrees[j])] = True
        self._tree = TreeDynamics(model)  # (its kinematics and RNEA of all steps at once)
        self.fall_height = fall_height
        # each step: t, q, v, the state after it, its ground contacts (StepContacts or None)
        self.steps: list[tuple] = []

    def observe(self, sim, k: int, t: float, q, v, step) -> None:
        self.steps.append((t, np.array(q), np.array(v), np.array(step.q), np.array(step.v),
                           sim.ground_step))  # fmt: skip
        if self.fall_height is not None and k % EVERY == 0:
            z = pin.centerOfMass(self.model, self.next, q)[2]
            if z < self.fall_height:
                raise RunFailed(f"the body fell at t = {t:.2f} s (centre of mass {z:.2f} m high)")

    def record(self, mass: float, dt: float) -> GaitRecord:
        """What the run's steps measure (see :class:`GaitRecord`), all steps at once."""
        model, n = self.model, len(self.steps)
        t = np.array([s[0] for s in self.steps], dtype=float)
        q, v, q_next, v_next = (np.array([s[i] for s in self.steps], dtype=float).reshape(n, nx)
                                for i, nx in ((1, model.nq), (2, model.nv), (3, model.nq),
                                              (4, model.nv)))  # fmt: skip
        # (a run that failed at its first step recorded nothing)
        found = [s[5] if s[5] is not None else _NO_STEP for s in self.steps] or [_NO_STEP]
        counts = np.array([len(f.impulses) for f in found[:n]], dtype=int)
        at = np.repeat(np.arange(n), counts)  # each point's step
        pts, local, forces = (
            np.concatenate([np.asarray(getattr(f, k), dtype=float).reshape(-1, 3) for f in found])
            for k in ("points", "local", "impulses")
        )  # fmt: skip
        joints = np.concatenate([np.asarray(f.joints, dtype=int) for f in found])
        forces = forces / dt
        side = self.side_of[joints]
        bearing = (forces[:, 2] > POINT_LOAD) & (side >= 0)
        kin = self._placements(q, v, (v_next - v) / dt, q_next, at, joints, local, bearing)
        R, O, M, W, soles, after = kin
        moved = after - pts[bearing]  # the bearing points' moves over their step
        # the ground's share of each joint's moment: RNEA's without external forces, less the
        # moments of the forces on the joint's subtree about its origin
        for j in self._moments:
            on = self._below[j, joints]
            M[j] -= _sums(cross(pts[on] - O[j][at[on]], forces[on]), at[on], n)
        flat = cross(pts * (1.0, 1.0, 0.0), forces)  # moments about the origin's vertical
        out: dict[str, dict[str, np.ndarray]] = {
            k: {} for k in ("force", "cop", "heel", "toe", "slip", "kinetics")
        }
        for i, s in enumerate(SIDES):
            on = side == i
            force, moment = _sums(forces[on], at[on], n), _sums(flat[on], at[on], n)
            fz = force[:, 2]
            out["force"][s] = force
            pressure = np.column_stack([-moment[:, 1], moment[:, 0]])
            with np.errstate(divide="ignore", invalid="ignore"):
                out["cop"][s] = np.where((fz > POINT_LOAD)[:, None], pressure / fz[:, None],
                                         np.nan)  # fmt: skip
            mine = on & bearing
            rot, origin = soles[s]
            along = np.einsum("ij,ij->i", pts[mine] - origin[at[mine]], rot[at[mine]])
            rear = along < self.middle[s]
            out["heel"][s] = np.bincount(at[mine][rear], minlength=n) > 0
            out["toe"][s] = np.bincount(at[mine][~rear], minlength=n) > 0
            fzs = forces[mine, 2]
            load = np.bincount(at[mine], weights=fzs, minlength=n)
            slip = _sums(fzs[:, None] * moved[mine[bearing], :2], at[mine], n)
            out["slip"][s] = slip / np.where(load > 0, load, 1.0)[:, None]
            out["kinetics"][s] = clinical_kinetics(
                self.chains[s], self.ankle[s], self.foot[s], R.__getitem__, M.__getitem__,
                W.__getitem__).reshape(n, len(_MOMENTS))  # fmt: skip
        return GaitRecord(t, q, v, mass=mass, dt=dt, **out)

    def _placements(self, q, v, a, q_next, at, joints, local, bearing) -> tuple:
        """What the kinetics read of each step: the kinetics' joints' world rotations R[j]
        (n, 3, 3), origins O[j] (n, 3), moments M[j] without the ground (RNEA's, about the
        joint's origin) and angular velocities W[j] (n, 3), world axes; the soles' placements
        by side (rotation's first column, origin: (n, 3) each); the bearing points' places
        after their step (k, 3). All steps in one compiled call
        (:class:`~humanoid.dynamics.TreeDynamics`), or step by step with Pinocchio."""
        points = np.flatnonzero(bearing)
        if self._tree.available:
            now = self._tree(q, v, a)
            R = {j: now.R[:, j] for j in self._rotations}
            O = {j: now.t[:, j] for j in self._rotations}
            M = {j: now.m[:, j] for j in self._moments}
            W = {j: now.w[:, j] for j in self._omegas}
            # the placements after the steps with bearing points (their rates play no part)
            steps, which = np.unique(at[points], return_inverse=True)
            zero = np.zeros((len(steps), self.model.nv))
            after = self._tree(q_next[steps], zero, zero)
            Rn, tn = after.R[which, joints[points]], after.t[which, joints[points]]
        else:
            R, O, M, W, Rn, tn = self._pinocchio(q, v, a, q_next, at, joints, points)
        moved = np.einsum("kij,kj->ki", Rn, local[points]) + tn
        soles = {}  # each sole's frame: its joint's placement times the frame's
        for s in SIDES:
            frame = self.model.frames[self.sole[s]].placement
            Rf = R[self.foot[s]]
            soles[s] = (Rf @ frame.rotation[:, 0], O[self.foot[s]] + Rf @ frame.translation)
        return R, O, M, W, soles, moved

    def _pinocchio(self, q, v, a, q_next, at, joints, points) -> tuple:
        """:meth:`_placements`' R, O, M, W and the bearing points' joints' placements after
        their step (rotations, translations), step by step with Pinocchio."""
        model, d, after = self.model, self.data, self.next
        n = len(q)
        H = {j: np.empty((n, 4, 4)) for j in self._rotations}  # the placements, homogeneous
        M = {j: np.empty((n, 3)) for j in self._moments}
        W = {j: np.empty((n, 3)) for j in self._omegas}
        Rn, tn = np.empty((len(points), 3, 3)), np.empty((len(points), 3))
        first = np.searchsorted(at[points], np.arange(n + 1))  # step i's: first[i]:first[i+1]
        for i in range(n):
            pin.forwardKinematics(model, d, q[i])  # (the placements: RNEA's are relative)
            pin.rnea(model, d, q[i], v[i], a[i])
            for j, Hj in H.items():
                Hj[i] = d.oMi[j].homogeneous
            for j, Mj in M.items():  # (in the joints' frames: turned to the world's below)
                Mj[i] = d.f[j].angular
            for j, Wj in W.items():
                Wj[i] = d.v[j].angular
            lo, hi = first[i], first[i + 1]
            if lo == hi:
                continue
            pin.forwardKinematics(model, after, q_next[i])
            for j in set(joints[points[lo:hi]].tolist()):
                placed = after.oMi[j]
                ks = lo + np.flatnonzero(joints[points[lo:hi]] == j)
                Rn[ks], tn[ks] = placed.rotation, placed.translation
        R = {j: Hj[:, :3, :3] for j, Hj in H.items()}
        O = {j: Hj[:, :3, 3] for j, Hj in H.items()}
        for X in (M, W):
            for j, Xj in X.items():
                X[j] = np.einsum("nij,nj->ni", R[j], Xj)
        return R, O, M, W, Rn, tn


@dataclass
class GroundWalk:
    """A walk on the ground: its trajectory (100 Hz), the per-step record, the cycle it
    tracked, the controller's counters, and the body that walked (a body with toes walks the
    fitted cycle with them locked: :func:`~humanoid.model.lock_foot_hinges`)."""

    trajectory: Trajectory
    record: GaitRecord
    cycle: GaitCycle
    relaxed: int
    wall_time: float
    steps: int
    body: Humanoid | None = None

    @property
    def completed(self) -> bool:
        return self.trajectory.metadata["status"] == "completed"

    @property
    def real_time_factor(self) -> float:
        """Simulated time over wall time (above 1: faster than real time)."""
        return (
            float(self.record.t[-1] + self.record.dt) / self.wall_time
            if len(self.record.t)
            else 0.0
        )


def walk_duration(cycle: GaitCycle, steps: int, phase0: float = PHASE0) -> float:
    """Time [s] to make ``steps`` heel strikes from ``phase0`` (the right heel strikes at
    phase 1, the left at 0.5), plus 0.3 s."""
    first = (1.0 - phase0) % 0.5 or 0.5
    return (first + (steps - 1) / 2) * cycle.period + 0.3


def walk_on_ground(h, speed: float | None = None, steps: int = 20, *, cycle=None, gains=None,
                   dt: float = 1e-3, mu: float = 0.8, pushes=(), quiet: bool = True,
                   from_standing: bool = False, radius: float | None = None,
                   record_rate: float = 100.0):  # fmt: skip
    """Simulate ``h`` walking ``steps`` steps on the rigid ground (see the module docstring).

    Args:
        h: The humanoid. speed: Walking speed [m/s] (default: the body's free speed).
        steps: Heel strikes to make. cycle: A fitted :class:`GaitCycle` (default: fitted here).
        gains: :class:`~humanoid.walking.tracking.TrackingGains`. dt: The step [s].
        mu: The floor's friction coefficient. pushes: :class:`~humanoid.scene.PushSpec` s
            (:func:`pelvis_push` makes one at a mid-stance). quiet: No progress bar.
        from_standing: Start standing still in the reference posture and stop standing
            (:mod:`~humanoid.walking.transitions`; the last of ``steps`` brings the feet together).
        radius: Walk along a circle of this radius [m] (positive turns left; default straight
            ahead). record_rate: The trajectory's samples per second (``1 / dt``: every step, as
            inverse dynamics needs to give back the controller's torques exactly).

    The walk starts from the cycle's own state at 20 % (the right foot in stance, the left in
    swing), unless ``from_standing``, and stops as failed at a fall; what it recorded up to
    then is kept. A body with toes walks with them locked (the fitted cycle plans a rigid
    foot); the walk's :attr:`GroundWalk.body` is the body that walked.
    """
    body = h
    h = lock_foot_hinges(h)
    if steps < 1:
        raise WalkError(f"steps must be at least 1, got {steps}")
    if radius is not None and not (math.isfinite(radius) and abs(radius) >= 0.5):
        raise WalkError(f"a curve's radius must be finite and at least 0.5 m, got {radius}")
    if radius is not None and from_standing:
        raise WalkError("a walk from standing along a curve is not supported yet")
    cycle = cycle if cycle is not None else fit_cycle(h, speed)
    if cycle.q.shape[1] != h.model.nq:  # fitted to the body with its toes free
        cycle = replace(cycle, q=restrict_configurations(cycle.q, body, h))
    ends = start_stop(h, cycle, steps) if from_standing else None
    scene = Scene(
        name="walk", body=h.source, ball_joints=h.ball_joints,
        duration=ends.t_end if ends else walk_duration(cycle, steps), dt=dt,
        integrator="semi_implicit_euler", record_rate=record_rate,
        effects=Effects(joint_limits=JointLimitSpec(kind="constraint"),
                        ground=GroundSpec(bodies="feet", mu=mu), pushes=tuple(pushes)),
    )  # fmt: skip
    sim = Simulation(scene, humanoid=h)
    ctl = GaitController(h, sim.model, cycle, sim.ground, dt, phase0=PHASE0,
                         gains=gains or TrackingGains(), transitions=ends,
                         radius=radius)  # fmt: skip
    if ends is None:
        q0, v0, _ = ctl.player.state(0.0)
    else:
        q0, v0 = ends.q0.copy(), np.zeros(sim.model.nv)
    z = pin.centerOfMass(sim.model, sim.model.createData(), q0)[2]
    recorder = GaitRecorder(h, sim.model, fall_height=FALL_HEIGHT * z)
    start = time.perf_counter()
    traj = sim.run(quiet=quiet, controller=ctl, monitors=[recorder], initial=(q0, v0))
    wall = time.perf_counter() - start
    record = recorder.record(h.mass, dt)
    return GroundWalk(traj, record, cycle, ctl.relaxed, wall, steps, h)


def pelvis_push(h, cycle, fraction: float, direction: str = "forward",
                step: int = 3, duration: float = 0.1) -> PushSpec:  # fmt: skip
    """A push at the pelvis of ``fraction`` of body weight for ``duration`` [s], horizontal in
    ``direction`` (forward, backward, left, right: the walk goes along +x), at the mid-stance
    of the right foot's ``step``-th stance of a :func:`walk_on_ground` walk of ``cycle`` (a
    fitted :class:`GaitCycle`, or an optimised gait that ``walk_cycle`` walks: they start at
    the same phase)."""
    if direction not in DIRECTIONS:
        raise WalkError(f"push direction must be one of {sorted(DIRECTIONS)}: {direction!r}")
    if fraction < 0 or duration <= 0 or step < 1:
        raise WalkError(
            f"a push needs fraction >= 0, duration > 0 and step >= 1, got {fraction}, "
            f"{duration}, {step}"
        )
    weight = h.mass * float(np.linalg.norm(h.model.gravity.linear))
    x, y = DIRECTIONS[direction]
    start = (step + MID_STANCE - PHASE0) * cycle.period
    return PushSpec(
        h.model.names[1], (fraction * weight * x, fraction * weight * y, 0.0), start, duration
    )


@dataclass
class PushTrials:
    """What :func:`largest_push` found: the largest push survived and the smallest that made
    the body fall [body weights] (None: none did, up to the search's limit), and every trial
    as (fraction, survived)."""

    direction: str
    survived: float
    fell: float | None
    trials: list


def largest_push(h, direction: str = "forward", cycle=None, *, walk=None, step: int = 3,
                 after: int = 4, duration: float = 0.1, resolution: float = 0.02,
                 first: float = 0.15, most: float = 1.0, progress=None) -> PushTrials:  # fmt: skip
    """The largest push at the pelvis (:func:`pelvis_push`) that the walking body survives:
    pushed at a mid-stance of its ``step``-th stride and walking ``after`` steps more without a
    fall. Doubles from ``first`` until a fall (or ``most``), then bisects to ``resolution`` [body
    weights]. ``progress(fraction, survived)`` is called after each trial.

    ``walk(steps, pushes) -> GroundWalk`` walks one trial (default :func:`walk_on_ground` of
    ``cycle``, fitted if None; give the cycle it walks, for the push's timing, with it: e.g.
    ``walk_cycle`` of an optimised gait and that gait)."""
    cycle = cycle if cycle is not None else fit_cycle(h)
    if walk is None:

        def walk(steps, pushes):
            return walk_on_ground(h, steps=steps, cycle=cycle, pushes=pushes)

    trials = []

    def survives(fraction: float) -> bool:
        push = pelvis_push(h, cycle, fraction, direction, step=step, duration=duration)
        walked = walk(2 * step + after, [push])
        trials.append((fraction, walked.completed))
        if progress is not None:
            progress(fraction, walked.completed)
        return walked.completed

    lo, hi, f = 0.0, None, first
    while hi is None and lo < most:
        f = min(f, most)
        if survives(f):
            lo, f = f, 2 * f
        else:
            hi = f
    while hi is not None and hi - lo > resolution:
        mid = 0.5 * (lo + hi)
        if survives(mid):
            lo = mid
        else:
            hi = mid
    return PushTrials(direction, lo, hi, trials)


# -- analysis ------------------------------------------------------------------------------


@dataclass
class GaitAnalysis:
    """What a gait lab reports of a walk (see the module docstring).

    Attributes:
        events: per side, ``strike`` and ``off`` times [s].
        cycles: per side, the (start, end) times of the analysed cycles.
        curves: per side, name -> (n_cycles, len(percent)) over :attr:`percent`.
        table: per cycle values: ``speed`` [m/s], ``cadence`` [steps/min], ``step_length``
            [m], ``stride_length`` [m], ``stance`` and ``double_support`` [fraction of the
            cycle], ``com_vertical`` and ``com_lateral`` (excursions) [m], one array each.
        feet: per side and stance, whether it went heel strike, foot flat, heel off, toe off;
            and the largest slide of its loaded points [m].
        dimensionless_speed: the walk's speed in leg lengths (for the normative bands).
        percent: the curves' samples of the cycle [%] (default :data:`PERCENT`, the normative
            data's 51).
    """

    events: dict
    cycles: dict
    curves: dict
    table: dict
    feet: dict
    dimensionless_speed: float
    mass: float
    source: str = ""
    percent: np.ndarray = field(default_factory=lambda: PERCENT)

    def mean(self, name: str, side: str | None = None) -> np.ndarray:
        """The mean curve of a side, or of both sides' cycles."""
        sides = [side] if side else list(SIDES)
        curves = [self.curves[s][name] for s in sides if len(self.curves[s][name])]
        return np.vstack(curves).mean(axis=0) if curves else np.full(len(self.percent), np.nan)

    def sd(self, name: str, side: str) -> np.ndarray:
        """The standard deviation over a side's cycles of a curve (zero for one cycle, NaN for
        none)."""
        c = self.curves[side][name]
        return c.std(axis=0) if len(c) else np.full(len(self.percent), np.nan)

    def side_table(self, side: str) -> dict:
        """:attr:`table`'s values of one side's cycles (from its heel strike), except
        ``step_length``: the side's own steps, each its heel strike's distance ahead of the
        other foot at its strike, measured along the stride (a cycle's row holds the other
        side's step: the one ending at the other foot's strike within it)."""
        counts = {s: len(self.cycles[s]) for s in SIDES}
        start = {"left": 0, "right": counts["left"]}  # (rows are appended side by side)
        rows = {s: slice(start[s], start[s] + counts[s]) for s in SIDES}
        other = OTHER[side]
        return {k: np.asarray(v)[rows[other if k == "step_length" else side]]
                for k, v in self.table.items()}  # fmt: skip

    def _norm(self, name: str, pelvis: str = "lab") -> tuple[np.ndarray, np.ndarray]:
        """The normative (mean, sd) of a curve at the walk's speed, on :attr:`percent`."""
        from .norms import norms

        n = norms()
        mean, sd = n.curve(name, self.dimensionless_speed, pelvis=pelvis)
        if len(self.percent) == len(n.percent) and np.array_equal(self.percent, n.percent):
            return mean, sd
        return np.interp(self.percent, n.percent, mean), np.interp(self.percent, n.percent, sd)

    def in_band(self, name: str, sds: float = 2.0) -> float:
        """The share of the cycle [0-1] where the mean curve of both sides lies within the
        normative mean +- ``sds`` SD at the walk's dimensionless speed (the norm as the body
        measures it: ``Norms.curve(..., pelvis="level")``); NaN without a cycle."""
        c = self.mean(name)
        if not np.isfinite(c).all():
            return float("nan")
        mean, sd = self._norm(name, pelvis="level")
        return float(np.mean(np.abs(c - mean) <= sds * sd))

    def roughness(self, name: str) -> float:
        """How much a mean curve zig-zags: its total variation (the sum of its steps' sizes)
        over the normative mean's at the walk's speed. A smooth curve of the norm's shape is
        near 1; spikes and oscillations raise it (a 1 N m/kg spike adds up to 2 N m/kg)."""
        c = self.mean(name)
        if not np.isfinite(c).all():
            return float("nan")
        mean, _ = self._norm(name)
        return float(np.abs(np.diff(c)).sum() / np.abs(np.diff(mean)).sum())

    def _peaks(self, side: str | None, stance: float) -> dict:
        """The peaks and troughs of one side's mean curves (``side`` None: both sides' mean),
        ``stance`` [% of the cycle] placing their windows."""
        pct = self.percent

        def window(name, lo, hi, fn):
            c = self.mean(name, side)
            sel = (pct >= lo) & (pct <= hi)
            return float(fn(c[sel])) if sel.any() else float("nan")

        out = {}
        fz = self.mean("grf_vertical", side)
        half = stance / 2
        first = (pct <= half) & (pct >= 5)
        second = (pct >= half) & (pct <= stance)
        i1 = np.flatnonzero(first)[np.argmax(fz[first])] if first.any() else 0
        i2 = np.flatnonzero(second)[np.argmax(fz[second])] if second.any() else 0
        out["grf_first_peak"] = float(fz[i1])
        out["grf_second_peak"] = float(fz[i2])
        out["grf_trough"] = float(fz[i1 : i2 + 1].min()) if i2 > i1 else float("nan")
        out["braking"] = -window("grf_anterior", 0, half, np.min)
        out["propulsion"] = window("grf_anterior", half, stance, np.max)
        out["knee_at_strike"] = float(self.mean("knee_flexion", side)[0])
        out["knee_loading"] = window("knee_flexion", 0, 25, np.max)
        out["knee_swing"] = window("knee_flexion", stance, 100, np.max)
        out["ankle_moment_peak"] = window("ankle_plantarflexion_moment", 0, stance, np.max)
        out["ankle_power_peak"] = window("ankle_power", 0, stance + 10, np.max)
        return out

    @property
    def summary(self) -> dict:
        """The walk's key numbers (means over the analysed cycles of both sides). A peak is
        each side's (of its mean curve), averaged over the sides, as a gait lab reports a
        limb's peaks: the peak of the two sides' mean curve is lower wherever the sides peak
        at different phases (a turn's inner and outer foot: the male's braking peaks were
        0.165 and 0.151 BW, their mean curve's 0.11)."""
        out = {k: float(np.mean(v)) if len(v) else float("nan") for k, v in self.table.items()}
        stance = out["stance"] * 100.0 if math.isfinite(out["stance"]) else 60.0
        sides: list[str | None] = [s for s in SIDES if len(self.curves[s]["grf_vertical"])]
        sides = sides or [None]
        peaks = [self._peaks(s, stance) for s in sides]
        out.update({k: float(np.mean([p[k] for p in peaks])) for k in peaks[0]})
        # the pelvis's and the arms' motion (each side's own curves, averaged)
        for name in ("pelvis_obliquity", "pelvis_rotation", "shoulder_flexion"):
            c = [np.ptp(self.mean(name, s)) for s in SIDES if len(self.curves[s][name])]
            out[name] = float(np.mean(c)) if c else float("nan")
        # the arms swing opposite the legs: each shoulder's flexion against its own hip's
        # (-1: exactly opposite)
        pairs = [(self.mean("shoulder_flexion", s), self.mean("hip_flexion", s))
                 for s in SIDES if len(self.curves[s]["shoulder_flexion"])]  # fmt: skip
        r = [np.corrcoef(a, b)[0, 1] for a, b in pairs if min(np.ptp(a), np.ptp(b)) > 1e-9]
        out["arm_leg_correlation"] = float(np.mean(r)) if r else float("nan")  # still: none
        feet = [f for s in SIDES for f in self.feet[s]]
        out["heel_to_toe"] = (
            sum(f["heel_strike"] and f["flat"] and f["heel_off"] and f["toe_off"] for f in feet)
            / len(feet) if feet else float("nan")
        )  # fmt: skip
        out["slip"] = max((f["slip"] for f in feet), default=float("nan"))
        out["cycles"] = sum(len(c) for c in self.cycles.values())
        for name in BAND_CURVES:
            out[f"{name}_in_band"] = self.in_band(name)
        out["roughness"] = max((self.roughness(n) for n in _MOMENTS), default=float("nan"))
        return out


def _kinematics(h, qs: np.ndarray, chains, arms):
    """Per configuration of ``qs``: each side's angles (:data:`ANGLES`, the pelvis's against
    the room, then :data:`ARM_ANGLES` if the body has arms), the centre of mass, the soles'
    positions and the pelvis's rotation."""
    model = h.model
    data = model.createData()
    n = len(qs)
    angles = {s: np.zeros((n, len(ANGLES) + len(ARM_ANGLES))) for s in SIDES}
    com = np.zeros((n, 3))
    soles = {s: np.zeros((n, 3)) for s in SIDES}
    pelvis = np.zeros((n, 3, 3))
    for i, q in enumerate(qs):  # one forward kinematics per sample serves all of them
        pin.framesForwardKinematics(model, data, q)
        com[i] = pin.centerOfMass(model, data, pin.KinematicLevel.POSITION, False)
        pelvis[i] = data.oMi[1].rotation
        for s in SIDES:
            angles[s][i, : len(ANGLES)] = chains[s].angles(data)
            if arms:
                angles[s][i, len(ANGLES) :] = arms[s].angles(data)
            soles[s][i] = data.oMf[h.sole_id(s)].translation
    return angles, com, soles, pelvis


def progression(com: np.ndarray, t: np.ndarray, window: float) -> np.ndarray:
    """[rad] the direction of progression at each sample: of the centre of mass's (N, 3)
    displacement over ``window`` [s] about it (a stride cancels its sway; clipped to the
    record at its ends), unwrapped."""
    ahead = np.column_stack([np.interp(np.clip(t + window / 2, t[0], t[-1]), t, com[:, i])
                             for i in range(2)])  # fmt: skip
    behind = np.column_stack([np.interp(np.clip(t - window / 2, t[0], t[-1]), t, com[:, i])
                              for i in range(2)])  # fmt: skip
    d = ahead - behind
    return np.unwrap(np.arctan2(d[:, 1], d[:, 0])) if len(t) else np.zeros(0)


def low_pass(x: np.ndarray, t: np.ndarray, cutoff: float = CUTOFF) -> np.ndarray:
    """``x`` (N, ...) sampled at times ``t`` [s], through a zero-lag Butterworth low-pass at
    ``cutoff`` [Hz] (second order, forwards and backwards); unchanged if the sampling is too
    slow or the record too short to filter."""
    from scipy.signal import butter, sosfiltfilt

    if len(t) < 16:
        return x
    fs = 1.0 / float(np.median(np.diff(t)))
    if cutoff >= 0.5 * fs:
        return x
    sos = butter(2, cutoff, fs=fs, output="sos")
    return sosfiltfilt(sos, x, axis=0, padtype="even")


def hysteresis(x: np.ndarray, on: float, off: float) -> np.ndarray:
    """Where a signal is "on": from each rise above ``on`` to the next fall below ``off``."""
    out = np.zeros(len(x), dtype=bool)
    state = False
    for i, value in enumerate(x):
        state = value > off if state else value > on
        out[i] = state
    return out


def contact_runs(x: np.ndarray, t: np.ndarray, shortest: float) -> list[tuple[int, int]]:
    """(start, end) index pairs of the True runs of x, runs and gaps shorter than ``shortest``
    [s] removed (gaps first: a bounce does not split a contact)."""

    def edges(y):
        d = np.diff(np.concatenate([[0], y.astype(int), [0]]))
        return list(zip(np.flatnonzero(d == 1), np.flatnonzero(d == -1), strict=True))

    x = x.copy()
    for a, b in edges(~x):
        if a > 0 and b < len(x) and t[b - 1] - t[a] < shortest:
            x[a:b] = True
    return [(a, b) for a, b in edges(x) if t[b - 1] - t[a] >= shortest]


def gait_kinematics(h, t: np.ndarray, qs: np.ndarray, stride: float, chains=None, arms=None):
    """What a gait lab measures of the configurations ``qs`` at times ``t`` [s]: each side's
    angles (N, 10) [deg] (:data:`ANGLES`, the pelvis's against the direction of progression,
    then :data:`ARM_ANGLES`, zero without arms), the centre of mass (N, 3) [m], the soles'
    positions (per side (N, 3) [m]) and the direction of progression (N,) [rad]: of the centre
    of mass's path over ``stride`` [s] about each sample (:func:`progression`)."""
    chains = chains if chains is not None else leg_chains(h)
    arms = arms if arms is not None else arm_chains(h, chains)
    angles, com, soles, pelvis = _kinematics(h, qs, chains, arms)
    # the pelvis against the direction of progression (a curve turns it; straight on, it is
    # the walk's drift): the centre of mass's path over one stride about each sample
    heading = progression(com, t, stride)
    for s in SIDES:
        angles[s][:, :3] = [
            chains[s].pelvis_angles(R, a) for R, a in zip(pelvis, heading, strict=True)
        ]
    return angles, com, soles, heading


def _at(x, times, tt):
    """The columns of x (n, m) at the times tt, linear between its ``times`` (n,)."""
    return np.array([np.interp(tt, times, x[:, i]) for i in range(x.shape[1])]).T


def _covers(series: tuple | None, t0, t1) -> TypeGuard[tuple]:
    """Whether a (times, ...) series spans [t0, t1]."""
    return series is not None and series[0][0] <= t0 and t1 <= series[0][-1]


def _contact_events(contacts: dict, te: np.ndarray) -> tuple[np.ndarray, dict]:
    """Double support at the samples ``te`` (both feet in contact), and each side's foot
    strikes and foot offs [s] (the finite ones) of its ``contacts``."""
    loaded = {s: np.zeros(len(te), dtype=bool) for s in SIDES}
    events = {}
    for s in SIDES:
        for on, off in contacts[s]:
            loaded[s] |= (te >= on) & (te <= off)
        events[s] = {"strike": [on for on, _ in contacts[s] if np.isfinite(on)],
                     "off": [off for _, off in contacts[s] if np.isfinite(off)]}  # fmt: skip
    return loaded["left"] & loaded["right"], events


def _cycle_curves(curves: dict, names, s: str, span: tuple, tt: np.ndarray, tk: np.ndarray,
                  kinematics: tuple, force, kinetics, scale: tuple,
                  loaded: bool) -> None:  # fmt: skip
    """Append a cycle's curves of side ``s`` (over ``span`` (t0, t1), sampled at ``tt``) to
    its ``curves``: its angles, and where their series cover it and the foot bears load, its
    ground force [body weights] and kinetics [per kg] (``scale``: (weight [N], mass [kg]))."""
    angles, _, _, heading = kinematics
    (t0, t1), (weight, mass) = span, scale
    ang = _at(angles[s], tk, tt)
    for j, name in enumerate(names):
        curves[name].append(ang[:, j])
    if _covers(force, t0, t1) and s in force[1] and loaded:
        f = _at(force[1][s], force[0], tt) / weight
        curves["grf_vertical"].append(f[:, 2])
        along = np.interp(tt, tk, heading)  # (a curve turns it within the stance)
        curves["grf_anterior"].append(f[:, 0] * np.cos(along)
                                      + f[:, 1] * np.sin(along))  # fmt: skip
    if _covers(kinetics, t0, t1) and loaded:
        kin = _at(kinetics[1][s], kinetics[0], tt) / mass
        for j, name in enumerate(_MOMENTS):
            curves[name].append(kin[:, j])


def _add_stride(table: dict, s: str, span: tuple, off: float, other_on: float, tt: np.ndarray,
                tk: np.ndarray, kinematics: tuple, te: np.ndarray,
                both: np.ndarray) -> None:  # fmt: skip
    """Append the spatiotemporal numbers of side ``s``'s stride over ``span`` (t0, t1) [s]
    (its foot off at ``off``, the other foot's strike at ``other_on``) to ``table``."""
    _, com, soles, _ = kinematics
    t0, t1 = span
    T = t1 - t0
    p0, p1 = (_at(soles[s], tk, np.array([x]))[0] for x in (t0, t1))
    stride = (p1 - p0)[:2]
    L = float(np.linalg.norm(stride))
    u = stride / L if L > 0 else np.array([1.0, 0.0])
    po = _at(soles[OTHER[s]], tk, np.array([other_on]))[0]
    table["speed"].append(L / T)
    table["cadence"].append(120.0 / T)
    table["stride_length"].append(L)
    table["step_length"].append(float((po - p0)[:2] @ u))
    table["stance"].append((off - t0) / T)
    table["double_support"].append(float(both[(te >= t0) & (te < t1)].mean()))
    c = _at(com, tk, tt)
    lateral = (c[:, :2] - c[0, :2]) @ np.array([-u[1], u[0]])
    lateral -= np.linspace(lateral[0], lateral[-1], len(lateral))
    table["com_vertical"].append(float(np.ptp(c[:, 2])))
    table["com_lateral"].append(float(np.ptp(lateral)))


def cycle_analysis(h, contacts: dict, te: np.ndarray, tk: np.ndarray, kinematics: tuple, *,
                   mass: float, force: tuple | None = None, kinetics: tuple | None = None,
                   window: tuple[float, float] = (-math.inf, math.inf), arms: bool = True,
                   percent: np.ndarray = PERCENT, speed: float | None = None,
                   require_load: bool = False, source: str = "") -> GaitAnalysis:  # fmt: skip
    """The gait cycles of a walk and what a gait lab reports of each (:func:`analyse`'s
    second half, shared with a lab trial's: :mod:`humanoid.walking.trial`).

    Args:
        h: The body (its leg length scales the speed). contacts: per side, each contact as
            (foot strike, foot off) times [s], ``-inf`` / ``inf`` where the record starts or
            ends in it. te: the times [s] on which double support is counted (the events'
            samples). tk: (N,) the kinematic samples [s]. kinematics: at ``tk``, what
            :func:`gait_kinematics` returns (angles, centre of mass, soles, heading).
        mass: [kg]. force: (times, per side (n, 3) [N]), the ground's force on each foot,
            world axes, already low-passed, or None. kinetics: (times, per side (n, 7)) the
            moments [N m] and powers [W] of :data:`_MOMENTS`, already low-passed, or None.
            A cycle outside their times gets no curve of them; with ``require_load``, neither
            does a cycle whose foot bears no load at mid-stance (a lab's plates catch some
            steps only).
        window: only the cycles within (start, end) [s]. arms: the arms' angles are curves.
        percent: the cycle's samples [%]. speed: [m/s] for the normative bands (default
            the cycles' mean). source: the walk's name.

    A cycle runs from a heel strike of its side to the next, if the foot came off and the
    other foot struck between them; its curves are sampled at ``percent`` of it (linear
    interpolation), the forces in body weights and the kinetics per kg of ``mass``.
    """
    g = float(np.linalg.norm(h.model.gravity.linear))
    weight = mass * g
    both, events = _contact_events(contacts, te)
    names = (*ANGLES, *ARM_ANGLES) if arms else ANGLES
    # lists per cycle, made arrays at the end
    curves: dict[str, dict[str, Any]] = {
        s: {n: [] for n in (*ANGLES, *ARM_ANGLES, *KINETICS)} for s in SIDES
    }
    table: dict[str, Any] = {
        k: []
        for k in ("speed", "cadence", "step_length", "stride_length", "stance",
                  "double_support", "com_vertical", "com_lateral")
    }  # fmt: skip
    cycles: dict[str, list[tuple[float, float]]] = {s: [] for s in SIDES}

    def bears(s, t0, off):
        if not require_load:
            return True
        if not _covers(force, t0, off) or s not in force[1]:
            return False
        # (over the contacts' threshold: a low-passed zero is 1e-44, not a load)
        return bool(np.interp(0.5 * (t0 + off), force[0], force[1][s][:, 2]) > EVENT_ON * weight)

    for s in SIDES:
        other = OTHER[s]
        strikes = [on for on, _ in contacts[s] if np.isfinite(on)]
        for t0, t1 in zip(strikes[:-1], strikes[1:], strict=True):
            if t0 < window[0] or t1 > window[1]:
                continue
            offs = [off for _, off in contacts[s] if t0 <= off < t1]
            others = [on for on, _ in contacts[other] if t0 < on < t1]
            if not offs or not others:
                continue
            cycles[s].append((t0, t1))
            T = t1 - t0
            tt = t0 + percent / 100.0 * T
            _cycle_curves(curves[s], names, s, (t0, t1), tt, tk, kinematics, force, kinetics,
                          (weight, mass), bears(s, t0, offs[0]))  # fmt: skip
            _add_stride(table, s, (t0, t1), offs[0], others[0], tt, tk, kinematics, te, both)
    curves = {s: {n: np.array(c).reshape(len(c), len(percent)) for n, c in cs.items()}
              for s, cs in curves.items()}  # fmt: skip
    table = {k: np.array(v) for k, v in table.items()}
    if speed is None:
        speed = float(np.mean(table["speed"])) if len(table["speed"]) else 0.0
    v_hat = speed / math.sqrt(g * leg_length(h))
    feet: dict[str, list[dict]] = {s: [] for s in SIDES}
    return GaitAnalysis(events, cycles, curves, table, feet, v_hat, mass, source, percent)


def analyse(h, walk: GroundWalk | GaitRecord, skip: float | None = None) -> GaitAnalysis:
    """A gait lab's analysis of a walk (see the module docstring).

    Args:
        h: The humanoid that walked (a :class:`GroundWalk` knows its own: its toes may have
            been locked). walk: the :class:`GroundWalk` (or its record).
        skip: Cycles that start before this time [s] are left out (default: the steady walk's
            start, the reference's ``steady[0]`` if it says, else one cycle period: the start
            from the reference's state is not a steady walk). Cycles that end after the
            reference's ``steady[1]`` (a stop) are left out too.
    """
    rec = walk.record if isinstance(walk, GroundWalk) else walk
    steady = (1.0, math.inf)
    if isinstance(walk, GroundWalk):
        steady = getattr(walk.cycle, "steady", (walk.cycle.period, math.inf))
    if isinstance(walk, GroundWalk) and walk.body is not None:
        h = walk.body
    skip = steady[0] if skip is None else skip
    model = h.model
    t, g = rec.t, float(np.linalg.norm(model.gravity.linear))
    weight = rec.mass * g
    chains = leg_chains(h)
    arms = arm_chains(h, chains)
    # kinematics at 100 Hz: angles, centre of mass, soles
    ks = np.arange(0, len(t), EVERY)
    tk = t[ks]
    # events from the raw vertical force, with hysteresis
    contacts = {}
    for s in SIDES:
        on = hysteresis(rec.force[s][:, 2], EVENT_ON * weight, EVENT_OFF * weight)
        runs = contact_runs(on, t, MIN_CONTACT)
        # a gap the record ends in, too short to tell a lift-off from a rigid contact's
        # zero-force samples, does not end the contact: the record does
        if runs and runs[-1][1] < len(t) and t[-1] - t[runs[-1][1]] < MIN_CONTACT:
            runs[-1] = (runs[-1][0], len(t))
        contacts[s] = runs
    strides = np.diff([t[a] for a, _ in contacts["right"] if a > 0])  # [s]
    stride = float(np.median(strides)) if len(strides) else 1.0
    kinematics = gait_kinematics(h, tk, rec.q[ks], stride, chains, arms)
    # forces, moments and powers low-passed before the cycles are sampled
    force = {s: low_pass(rec.force[s], t) for s in SIDES}
    kinetics = {s: low_pass(rec.kinetics[s], t) for s in SIDES}
    feet: dict[str, list[dict]] = {s: [] for s in SIDES}
    for s in SIDES:
        for a, b in contacts[s]:  # every complete stance: the foot's rocker sequence
            if a == 0 or b == len(t):
                continue
            heel, toe = rec.heel[s][a:b], rec.toe[s][a:b]
            flat = heel & toe
            first = np.flatnonzero(heel | toe)
            last = first[-1] if len(first) else 0
            i_flat = np.flatnonzero(flat)
            # the slide while the foot bears weight (above the contact's start threshold: the
            # hysteresis's tail, the last 1-2 % of body weight, pivots the foot off)
            bearing = rec.force[s][a:b, 2] > EVENT_ON * weight
            slide = np.cumsum(rec.slip[s][a:b] * bearing[:, None], axis=0)
            feet[s].append({
                "time": float(t[a]),
                "heel_strike": bool(len(first)) and heel[first[0]] and not toe[first[0]],
                "flat": bool(len(i_flat)),
                "heel_off": bool(len(i_flat)) and bool((toe & ~heel)[i_flat[-1]:].any()),
                "toe_off": bool(len(first)) and toe[last] and not heel[last],
                "slip": float(np.linalg.norm(slide - slide[0], axis=1).max()),
            })  # fmt: skip
    times = {s: [(t[a] if a > 0 else -math.inf, t[b - 1] if b < len(t) else math.inf)
                 for a, b in contacts[s]] for s in SIDES}  # fmt: skip
    out = cycle_analysis(h, times, t, tk, kinematics, mass=rec.mass, force=(t, force),
                         kinetics=(t, kinetics), window=(skip, steady[1]), arms=bool(arms),
                         source=h.source)  # fmt: skip
    out.feet = feet
    return out
