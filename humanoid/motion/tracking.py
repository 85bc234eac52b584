"""Physics-based tracking: a recorded motion followed in forward simulation, by joint torques.

The seeds' people tracking: a kinematic motion (from inverse kinematics of noisy markers or
keypoints, say) is turned into one that obeys physics. The plant is the walk's: the rigid
ground contact (every sole point unilateral with Coulomb friction), the joint ranges as
constraints, semi-implicit Euler; the free flyer is never actuated, so the body goes where the
ground's forces take it. At every step a task-space inverse-dynamics QP (ProxQP), the walk
controller's (:mod:`humanoid.walking.tracking`) without its gait cycle, finds the acceleration
``dv`` and the forces ``f`` of the sole points that carry load, and only the joint torques
``tau = (M dv + h - J^T f)[6:]`` leave it:

- **Reference.** The motion resampled, filtered (6 Hz by default) and differentiated as
  inverse dynamics does (:func:`~humanoid.motion.inverse_dynamics.derivatives`), interpolated
  at the simulation's steps.
- **Contacts.** Which foot is on the ground when: from the measured loads if there are any
  (vertical force over 20 N), else from the motion, a foot whose lowest sole point is within
  ``contact_height`` of the motion's floor and moves slower than ``contact_speed``. A foot in
  contact whose sole points are within ``touch`` of the floor sticks (its points' forces are the
  QP's, in friction pyramids); a foot out of contact follows the motion's foot, and none of its
  points may go through the floor within the ``horizon``.
- **Tasks.** The root (pelvis position and orientation) and the centre of mass follow the
  motion's, the centre of mass's horizontal acceleration kept to one the loaded soles can carry
  (its centre of pressure moved into their hull); every joint follows its angle; a free foot
  its pose, moved as it swings by the capture point's error, to land on the error's capture
  point (a body behind the motion steps shorter, as a person catching up does; one drifting
  sideways steps under itself: ``TrackGains.placement``); small forces.

The result (:class:`Tracked`) is the simulated run, with its contact forces and torques, and the
tracking error per joint against the reference.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import TYPE_CHECKING

import numpy as np
import pinocchio as pin

from ..control.qp import WarmQP, checked, contact_qp, dynamics_terms, feet_contacts
from ..control.tasks import CentreOfMassTask, FrameTask, PostureTask, TaskStack
from ..effects import Effect
from ..errors import RunFailed
from ..model import SIDES
from ..walking.tracking import RANGE_MARGIN, RANGE_TIME, SOLE_DEPTH
from .coordinates import lowest_sole_point, lowest_sole_points
from .inverse_dynamics import contact_schedule, derivatives, residual_cutoff
from .loads import Load

if TYPE_CHECKING:
    from ..model import Humanoid
    from ..trajectory import Trajectory
    from .floor import Floor

__all__ = [
    "MotionReference",
    "MotionTracker",
    "ReferenceRangeWarning",
    "TrackGains",
    "Tracked",
    "foot_joints",
    "inside_ranges",
    "reference_floor",
    "toes_on_floor",
    "track",
]


class ReferenceRangeWarning(UserWarning):
    """The motion to track went past joint ranges (which the simulation keeps): clamped."""


LWA = pin.ReferenceFrame.LOCAL_WORLD_ALIGNED
# [Hz] the automatic cutoff is never below this: a walk's feet need their stride's first three
# harmonics (about 1 Hz each). Keypoints with 1 cm of noise at 30 Hz: Winter's 2.0-2.4 Hz
# tracked 4 walks of 5 (3 of 5 from four cameras' pixels), falling in the last step; at 3 Hz,
# 5 of 5 each way; at 6 Hz, 2 of 5
LOWEST_CUTOFF = 3.0
# [Hz] ... nor above this, Winter's usual for walking: a clean walk's residual analysis finds
# 17.5 Hz at 100 Hz, and its impacts then reach the reference's accelerations (tracked, the
# joints were 3.2 degrees off at worst, 1.95 at 6 Hz)
HIGHEST_CUTOFF = 6.0
# [s] the simulation's and the controller's step. 1 ms before; at 2 ms OpenSim's subject01
# walk (IK, reduced, on its fitted floor) tracked 1.57 deg RMS off its reference (1.87 at
# 1 ms) at twice the speed
DT = 2e-3


@dataclass(frozen=True)
class TrackGains:
    """The tracking QP's gains and weights (accelerations: kp e + kd e')."""

    joint_kp: float = 400.0
    joint_kd: float = 40.0
    root_kp: float = 100.0
    root_kd: float = 20.0
    com_kp: float = 100.0
    com_kd: float = 20.0
    foot_kp: float = 400.0
    foot_kd: float = 40.0
    w_joint: float = 1.0
    w_root: float = 10.0
    w_com: float = 10.0
    w_foot: float = 10.0
    w_force: float = 1e-3
    mu: float = 0.6  # the pyramids' friction (inside the floor's)
    touch: float = 1e-2  # [m] a contact foot's points this close to the floor may bear load
    ref_touch: float = 1e-2  # [m] ... if the motion has them this close to its floor,
    ref_reach: float = 3e-2  # [m] ... or this close and rising slower than ref_rise [m/s]:
    ref_rise: float = 0.05  # (with 1 cm alone, a fitted noisy motion's standing heel rose
    # past it and the body fell; with 2 cm alone, a clean walk's heel was held 6 degrees down)
    contact_time: float = 0.02  # [s] a loaded point's velocity comes to rest in this time
    settle: float = 0.02  # [s] a loaded point above the floor settles onto it in this time
    horizon: float = 0.02  # [s] free points and ranges are kept off their bounds this far ahead
    # a swinging foot lands this much of the capture point's error (the centre of mass's
    # position error plus its velocity error over omega = sqrt(g / height)) away from the
    # motion's foot, growing from none at lift-off to all of it at landing (0: where the
    # motion's lands). 1: on the error's capture point, which stops it (a linear inverted
    # pendulum's). A fraction p leaves (1 - p) of it to grow by exp(omega T) over the next
    # stance T (about 4.7 on a walk's 0.5 s at omega 3.1): below p = 1 - exp(-omega T), about
    # 0.8, an error the stance foot's centre of pressure cannot take back grows step after
    # step. OpenSim's subject01 treadmill walk, reduced: at 0 the body fell behind the motion
    # by 30 cm at 2.4 s of 2.5; at 0.5 its converged IK fit fell sideways at 1.65 s, the
    # capture point's lateral error at the landings 2.4, 16.7, 59.3 cm (its earlier,
    # unconverged fit completed, the error 3.2, 4.8, 2.7, 3.8 cm); at 1 both complete
    placement: float = 1.0
    w_toes: float = 10.0  # a free toe hinge's (MTP) weight in the joints' task


# [m] a rearfoot's point this near a loaded point of its toes is the ball of the foot, the
# toes' (their rear corners and its front ones are one edge with the toes flat, 8 mm apart
# with them bent 30 deg)
BALL = 1e-2


class FallMonitor:
    """Stops a run as failed when the centre of mass drops below ``fraction`` of its height
    at the start, or the pelvis tips more than ``tip`` [deg] from upright (no one walks so; a
    body that crumples onto its knees keeps its centre of mass above half its height)."""

    def __init__(self, model, q0, fraction: float = 0.5, tip: float = 60.0) -> None:
        self.model, self.data = model, model.createData()
        self.limit = fraction * float(pin.centerOfMass(model, self.data, q0)[2])
        self.tip = math.cos(math.radians(tip))
        self.up = float(pin.Quaternion(q0[6], q0[3], q0[4], q0[5]).toRotationMatrix()[2, 2])

    def observe(self, sim, k: int, t: float, q, v, step) -> None:
        if k % 10:
            return
        if pin.centerOfMass(self.model, self.data, q)[2] < self.limit:
            raise RunFailed(f"the body fell at t = {t:.2f} s")
        up = float(pin.Quaternion(q[6], q[3], q[4], q[5]).toRotationMatrix()[2, 2])
        if up < self.tip and self.up >= self.tip:
            raise RunFailed(
                f"the body fell at t = {t:.2f} s (the pelvis tipped "
                f"{math.degrees(math.acos(max(-1.0, up))):.0f} deg from upright)"
            )


def _swings(times, on) -> list[tuple[float, float]]:
    """The schedule's swings: (lift-off, landing) times [s] of each run without contact."""
    on = np.asarray(on, dtype=bool)
    edges = np.flatnonzero(np.diff(on.astype(int)))
    out, start = [], None if on[0] else float(times[0])
    for e in edges:
        if on[e] and not on[e + 1]:
            start = float(times[e + 1])
        elif start is not None:
            out.append((start, float(times[e + 1])))
            start = None
    if start is not None:
        out.append((start, float(times[-1]) + 1e-9))
    return out


class MotionReference:
    """The motion (uniform samples of q, v, a) at any time: q interpolated on the group,
    v and a linearly; before the first sample the first, after the last the last at rest."""

    def __init__(self, model, time, q, v, a, floor: float = 0.0) -> None:
        self.model, self.time, self.q, self.v, self.a = model, time, q, v, a
        self.rate = 1.0 / (time[1] - time[0])
        self.floor = floor  # the height of the motion's floor [m]

    def state(self, t: float):
        x = (t - self.time[0]) * self.rate
        if x <= 0.0:
            return self.q[0].copy(), self.v[0].copy(), self.a[0].copy()
        i = int(math.floor(x))
        if i >= len(self.time) - 1:
            return self.q[-1].copy(), np.zeros(self.model.nv), np.zeros(self.model.nv)
        u = x - i
        q = pin.interpolate(self.model, self.q[i], self.q[i + 1], u)
        return q, (1 - u) * self.v[i] + u * self.v[i + 1], (1 - u) * self.a[i] + u * self.a[i + 1]


class MotionTracker(Effect):
    """The tracking controller (see the module docstring): an effect whose torques the
    simulation applies, computed once per step in ``before_step``."""

    name = "tracking"

    def __init__(self, h, model, reference: MotionReference, contacts: dict, ground, dt: float,
                 gains: TrackGains | None = None) -> None:  # fmt: skip
        from ..constraints.limits import JointRanges

        self.h, self.model, self.ref = h, model, reference
        self.contacts = contacts  # side -> (times, bool array)
        self.ground, self.dt = ground, dt
        self.gains = gains or TrackGains()
        self.data, self.rdata = model.createData(), model.createData()
        self.cdata = model.createData()
        self.g = float(np.linalg.norm(model.gravity.linear))
        self.swings = {s: _swings(*contacts[s]) for s in SIDES}
        self.sole = {s: h.sole_id(s) for s in SIDES}
        self.foot_joint = {s: model.frames[self.sole[s]].parentJoint for s in SIDES}
        self.foot_joints = {s: foot_joints(h, s) for s in SIDES}
        self.toes = any(len(js) > 1 for js in self.foot_joints.values())
        # the joints' task weights: a foot's own hinges (its toes') weigh w_toes
        from ..constraints import foot_hinges

        self.w_joints = np.full(model.nv - 6, self.gains.w_joint)
        for s in SIDES:
            frames = [h.frame_id(n) for n in h.contact_points[s]]
            for j in foot_hinges(model, self.sole[s], frames):
                self.w_joints[model.joints[j].idx_v - 6] = self.gains.w_toes
        self.weight = h.mass * float(np.linalg.norm(model.gravity.linear))
        self.ranges = JointRanges(h)
        self.tau = np.zeros(model.nv)
        self.qp = WarmQP(eps_abs=1e-9, max_iter=1000, primal=1e-7, dual=1e-4)
        self.relaxed = 0
        # the last solve: (accelerations, contact forces, the loaded points)
        self.last: tuple[np.ndarray, np.ndarray, list[int]] | None = None

    def force(self, model, data, t, q, v):
        return self.tau

    def before_step(self, sim, k: int, t: float, q, v) -> None:
        self.tau = self.update(t, q, v)

    def swing_phase(self, side: str, t: float) -> float:
        """How far through its swing the foot is at ``t`` (0 at lift-off, 1 at landing; 1
        outside a scheduled swing)."""
        for a, b in self.swings[side]:
            if a <= t < b:
                return (t - a) / (b - a)
        return 1.0

    def in_contact(self, side: str, t: float) -> bool:
        times, on = self.contacts[side]
        i = int(np.clip(np.searchsorted(times, t), 0, len(times) - 1))
        return bool(on[i])

    def _ball(self, joints, phi, points, loaded, free):
        """(loaded, free) with, of a rearfoot's loaded point and a loaded point of its toes
        within :data:`BALL` of each other (the ball of the foot), the higher made free (the
        rearfoot's with the toes flat and the heel up, the toes' with the toes bent up on a
        flat foot). Both loaded, they locked the foot: a rearfoot turning about the MTP axis
        moves its ball backwards under toes that stand still (walking5's stance foot stood on
        its ball with its heel and toes up, pushed 2.6 BW and flew), and a point 0.7 mm up
        settling onto the floor turned a standing body's toes down from 17 degrees to 0."""
        joint = {i: int(joints[i]) for i in loaded}
        parents = self.model.parents
        out = []
        for i in loaded:
            higher = any(
                (parents[joint[k]] == joint[i] and phi[i] >= phi[k])
                or (parents[joint[i]] == joint[k] and phi[i] > phi[k])
                for k in loaded
                if np.linalg.norm(points[k][:2] - points[i][:2]) < BALL
            )
            (free if higher else out).append(i)
        return out, free

    def update(self, t: float, q, v) -> np.ndarray:
        model, data, g, dt = self.model, self.data, self.gains, self.dt
        M, hvec = dynamics_terms(model, data, q, v)
        found, side_of = feet_contacts(self.ground, model, data, self.foot_joints, q)
        phi, points = found.phi, found.points
        on = {s: self.in_contact(s, t) for s in SIDES}
        q_r, v_r, a_r = self.ref.state(t)
        rd = self.rdata
        pin.forwardKinematics(model, rd, q_r, v_r, a_r)
        pin.updateFramePlacements(model, rd)
        loaded: list[int] = []
        free: list[int] = []
        for i, s in enumerate(side_of):
            ok = False
            if s is not None and on[s] and phi[i] < g.touch:
                # the point on its own body (the rearfoot or the toes)
                j = int(found.joints[i])
                local = found.local[i]
                # a point of the sole that the motion has on the floor now: low, and not
                # rising away from it (a heel rising in push-off is not held down; a fitted
                # noisy motion's standing heel, a centimetre or two up, is)
                M_r = rd.oMi[j]
                ref_z = float(M_r.act(local)[2]) - self.ref.floor
                vel = pin.getVelocity(model, rd, j, LWA)
                w, r = vel.angular, M_r.rotation @ local  # (np.cross's z: 20 us, this 1)
                rising = float(vel.linear[2] + (w[0] * r[1] - w[1] * r[0]))
                ok = self.foot_joints[s][j].act(local)[2] < SOLE_DEPTH and (
                    ref_z < g.ref_touch or (ref_z < g.ref_reach and rising < g.ref_rise)
                )
            (loaded if ok else free).append(i)
        loaded, free = self._ball(found.joints, phi, points, loaded, free)
        bearing = {side_of[i] for i in loaded}
        if self.toes:  # a bearing foot's free points are the plant's to keep out of the floor
            free = [i for i in free if side_of[i] not in bearing]
        tasks = TaskStack(model, data, q, v)
        # the root: position and orientation
        tasks.add(PostureTask(q_r, g.root_kp, g.root_kd, g.w_root, v_r, a_r, dofs="root"))
        # the centre of mass, its horizontal acceleration one the loaded soles can carry
        c_r = pin.centerOfMass(model, rd, q_r, v_r, a_r)
        dc_r, ddc_r = rd.vcom[0].copy(), rd.acom[0].copy()
        support = np.array([points[i][:2] for i in loaded]).reshape(-1, 2)
        tasks.add(CentreOfMassTask(c_r, dc_r, ddc_r, g.com_kp, g.com_kd, g.w_com, support))
        # free feet follow the motion's, moved by the capture point's error as they swing
        shift = None
        if g.placement:
            c = pin.centerOfMass(model, self.cdata, q, v)
            omega = math.sqrt(self.g / max(float(c_r[2] - self.ref.floor), 0.3))
            error = (c - c_r) + (self.cdata.vcom[0] - dc_r) / omega
            shift = g.placement * error[:2]
        for s in SIDES:
            if s not in bearing:
                moved = None if shift is None else self.swing_phase(s, t) * shift
                tasks.add(FrameTask.following(model, rd, self.sole[s], g.foot_kp, g.foot_kd,
                                              g.w_foot, moved))  # fmt: skip
        tasks.add(PostureTask(q_r, g.joint_kp, g.joint_kd, self.w_joints, v_r, a_r))
        p = contact_qp(model, data, self.ground, found, loaded, free, tasks, M, hvec, q, v, dt,
                       self.weight, g, self.ranges, RANGE_MARGIN, RANGE_TIME)  # fmt: skip
        x, relaxed = p.solve(self.qp)
        self.relaxed += relaxed
        tau, dv, f = p.torques(checked(x, "tracking", t, self.qp), M, hvec, self.weight)
        self.last = (dv, f, loaded)
        return tau


def foot_joints(h, side: str) -> dict:
    """The joints of a side's foot (its sole's and those below it: a foot with free toes, its
    toes'), each with its placement in the sole's frame when the body stands (a point's
    height above the sole's plane with the toes flat)."""
    model = h.model
    data = model.createData()
    pin.framesForwardKinematics(model, data, h.standing_configuration())
    sole = data.oMf[h.sole_id(side)]
    root = model.frames[h.sole_id(side)].parentJoint
    return {j: sole.actInv(data.oMi[j]) for j in model.subtrees[root]}


def toes_on_floor(h, q, floor: float | None = None) -> tuple[np.ndarray, dict]:
    """The configurations ``q`` (n, nq) with each foot's own hinges (its toes' MTP) turned,
    where the motion has the points they carry under the floor at height ``floor`` [m], just
    enough to bring them onto it (within the hinge's range), and what was turned: {hinge:
    (frames, the most it turned [rad])}. ``floor`` None: the median over the frames of the
    lowest sole point. A motion fitted with the toes locked (or on a model without them) has a
    rigid foot: walking5's tips went 3-5 cm through the floor at every push-off, where a foot
    rolls over its toes (with them flat, its sole stayed out of the floor in every frame)."""
    from ..constraints import foot_hinges

    model = h.model
    data = model.createData()
    out = np.array(q, dtype=float)
    hinges = []  # (hinge, its q index, the sole points it carries)
    for s in SIDES:
        frames = [h.frame_id(n) for n in h.require_contact_points(s)]
        for j in foot_hinges(model, h.sole_id(s), frames):
            below = [f for f in frames if model.frames[f].parentJoint in model.subtrees[j]]
            hinges.append((model.names[j], model.joints[j].idx_q, below))
    if not hinges:
        return out, {}

    def lowest(qi, frames):
        pin.forwardKinematics(model, data, qi)
        return min(float(pin.updateFramePlacement(model, data, f).translation[2]) for f in frames)

    if floor is None:
        every = [h.frame_id(n) for s in SIDES for n in h.require_contact_points(s)]
        floor = float(np.median([lowest(qi, every) for qi in out]))
    turned: dict[str, tuple[int, float]] = {}
    for name, iq, below in hinges:
        lo, hi = model.lowerPositionLimit[iq], model.upperPositionLimit[iq]
        for qi in out:
            a0 = float(qi[iq])
            if lowest(qi, below) >= floor:
                continue
            ends = []  # the limit whose angle lifts the points more
            for end in (lo, hi):
                qi[iq] = end
                ends.append((lowest(qi, below), end))
            lift, end = max(ends)
            a, b = a0, end
            if lift > floor:  # bisection for the points on the floor
                for _ in range(30):
                    qi[iq] = 0.5 * (a + b)
                    a, b = (qi[iq], b) if lowest(qi, below) < floor else (a, qi[iq])
            qi[iq] = b
            k, most = turned.get(name, (0, 0.0))
            turned[name] = (k + 1, max(most, abs(b - a0)))
    return out, turned


def inside_ranges(h, q) -> tuple[np.ndarray, dict[str, tuple[int, float]]]:
    """The configurations ``q`` (n, nq) with every joint inside its range (a ball joint's
    angles: those of the hinge triplet it replaces), and what was clamped: {joint or hinge:
    (frames, the most it was past [rad])}. The simulation keeps every range, so a reference
    past one cannot be followed there: on OpenSim's subject01 walk the fitted spine bent
    80 deg, 35 past its range, and tracking fell at 1.6 s; clamped first, it completed."""
    from ..constraints.limits import JointRanges

    ranges = JointRanges(h)
    names = ranges.names()
    out = np.empty_like(np.asarray(q, dtype=float))
    past = np.zeros((len(out), len(names)))
    for i, qi in enumerate(np.asarray(q, dtype=float)):
        out[i], past[i] = ranges.clamp(qi)
    over = past > 1e-9
    return out, {name: (int(over[:, k].sum()), float(past[:, k].max()))
                 for k, name in enumerate(names) if over[:, k].any()}  # fmt: skip


def describe_clamped(clamped: dict, frames: int) -> str:
    """One line for :func:`inside_ranges`'s report: "thoracic_flexion in 151 of 151 frames,
    by up to 38.7 deg; ...", the largest first."""
    order = sorted(clamped.items(), key=lambda kv: -kv[1][1])
    return "; ".join(f"{n} in {k} of {frames} frames, by up to {math.degrees(x):.1f} deg"
                     for n, (k, x) in order)  # fmt: skip


@dataclass
class Tracked:
    """A tracked motion.

    Attributes:
        trajectory: The simulated run (:class:`~humanoid.trajectory.Trajectory`; its forces
            include each leg's ground wrench). reference: (time, q) of the motion followed, at
            the run's records. joint_error: per record, each joint's error against the
            reference [rad] (the root's 6 first: position [m] and orientation [rad]).
        contacts: side -> (times, in contact) as scheduled. wall_time: [s]. body: the body
            that moved (with ``toes=False`` its toes locked:
            :func:`~humanoid.model.lock_foot_hinges`). cutoff: the reference's low-pass
            cutoff [Hz] (None: unfiltered). floor: the
            :class:`~humanoid.motion.floor.Floor` whose frame the run is in (None: the
            motion's own). toes: what the reference's toes were turned by to bring them
            onto the floor (:func:`toes_on_floor`).
    """

    trajectory: Trajectory
    reference: tuple
    joint_error: np.ndarray
    contacts: dict
    wall_time: float
    body: Humanoid | None = None
    cutoff: float | None = None
    floor: Floor | None = None
    toes: dict = field(default_factory=dict)

    @property
    def completed(self) -> bool:
        """Whether the run reached the motion's end (it may have lost the motion on the way:
        :attr:`lost`)."""
        return self.trajectory.status == "completed"

    @property
    def lost(self) -> float | None:
        """The time [s, the run's] at which its pelvis first went over :data:`LOST_POSITION`
        or :data:`LOST_ANGLE` from the motion's, or None if it never did: a run can complete
        standing a metre from the motion it was to follow."""
        i = lost_at(self.joint_error)
        return None if i is None else float(self.trajectory.t[i])


def track(h, time, q, loads: list[Load] | tuple = (), *, cutoff: float | str | None = "auto",
          dt: float = DT, mu: float = 0.8, gains: TrackGains | None = None,
          record_rate: float = 100.0, quiet: bool = True, floor=None,
          toes: bool = False) -> Tracked:  # fmt: skip
    """Follow the motion ``q`` (n, nq) at ``time`` in forward simulation (see the module
    docstring); ``loads`` (measured ground forces) only say when each foot is on the ground.
    ``cutoff``: the reference's low-pass cutoff [Hz]; ``"auto"`` (the default): Winter's
    residual analysis of the motion (:func:`~humanoid.motion.inverse_dynamics.
    residual_cutoff`: a noisy motion or one at a video's rate is smoothed more), between
    :data:`LOWEST_CUTOFF` and :data:`HIGHEST_CUTOFF`.

    A motion past joint ranges (which the run keeps) is clamped into them first
    (:func:`inside_ranges`; a :class:`ReferenceRangeWarning` names what). The run starts in the
    reference's first state; it stops as failed if the body falls (its
    centre of mass below half its starting height, or its pelvis tipped over 60 deg), the
    message saying when and how it lost the motion; what it recorded up to then is kept.

    ``toes``: False (default): a body with toes tracks with them locked
    (:func:`~humanoid.model.lock_foot_hinges`, one rigid foot). True: it keeps its toe hinges
    (MTP) free: their angles are tracked as every joint's (weighted ``TrackGains.w_toes``),
    their sole points bear load as the rearfoot's (the toes' rear corners, not the rearfoot's
    front ones, are the ball of the foot), and where the motion has them under its floor (a
    motion fitted with the toes locked: a rigid foot's tip 3-5 cm through the floor at
    push-off) the reference turns them onto it (:func:`toes_on_floor`), so that the body rolls
    over its toes. Not the default: walking5 (a Vicon walk) then ends 69 cm from its motion
    (7 locked), and OpenSim's subject01 walk's joints are 2.2 deg RMS off (1.6 locked); see
    docs/motion.md. The result's :attr:`Tracked.body` is the body that moved.

    ``floor``: the :class:`~humanoid.motion.floor.Floor` the motion was recorded on
    (:func:`~humanoid.motion.floor.fit_floor`), or ``"fit"`` to fit it: the motion is followed
    in the floor's frame (:meth:`~humanoid.motion.floor.Floor.onto`: level, moving with a
    treadmill's belt, under gravity turned as the floor is), and the run is recorded in that
    frame; default None: on a horizontal plane under the motion's stances
    (:func:`reference_floor`).
    """
    import time as clock

    from ..model import lock_foot_hinges
    from ..scene import Effects, GroundSpec, JointLimitSpec, Scene
    from ..simulation import Simulation
    from .floor import LEVEL

    full, h = h, h if toes else lock_foot_hinges(h)
    q, floor, gravity, turned = _motion_on_floor(full, h, time, q, floor, toes)
    model = h.model
    if cutoff == "auto":
        cutoff = min(max(residual_cutoff(model, time, q), LOWEST_CUTOFF), HIGHEST_CUTOFF)
    t, qf, vf, af = derivatives(model, time, q, cutoff=cutoff)
    contacts = contact_schedule(h, t, qf, vf, loads, floor=None if floor is None else LEVEL)
    duration = float(t[-1] - t[0])
    scene = Scene(
        name="track", body=h.source, ball_joints=h.ball_joints, duration=duration, dt=dt,
        integrator="semi_implicit_euler", record_rate=record_rate,
        effects=Effects(gravity=tuple(float(x) for x in gravity),  # type: ignore[arg-type]  # (3 floats)
                        joint_limits=JointLimitSpec(kind="constraint"),
                        ground=GroundSpec(bodies="feet", mu=mu)),
    )  # fmt: skip
    sim = Simulation(scene, humanoid=h)
    base = reference_floor(h, qf) if floor is None else 0.0
    shifted = MotionReference(model, t - t[0], qf, vf, af, floor=base)
    contacts = {s: (times - t[0], on) for s, (times, on) in contacts.items()}
    ctl = MotionTracker(h, sim.model, shifted, contacts, sim.ground, dt, gains)
    q0, v0, _ = shifted.state(0.0)
    # a fitted floor is a plane through the stances: a foot may start a centimetre in it, and
    # the run would open with an impact; it starts on it
    q0[2] += max(0.0, base - lowest_sole_point(h, q0[None]))
    start = clock.perf_counter()
    traj = sim.run(quiet=quiet, controller=ctl, monitors=[FallMonitor(sim.model, q0)],
                   initial=(q0, v0))  # fmt: skip
    wall = clock.perf_counter() - start
    ref_q, err = _errors(model, traj, shifted, ctl)
    # (cutoff is a number or None here: "auto" was resolved above)
    return Tracked(traj, (traj.t + t[0], ref_q), err, contacts, wall, h,
                   cutoff, floor, turned)  # type: ignore[arg-type]  # fmt: skip


def _motion_on_floor(full, h, time, q, floor, toes: bool):
    """:func:`track`'s motion on the body ``h`` that moves (``full`` with its toes locked, or
    itself), inside its ranges (a :class:`ReferenceRangeWarning` if clamped), in the floor's
    frame (``floor`` a :class:`~humanoid.motion.floor.Floor`, ``"fit"`` or None) and with its
    toes on the floor with ``toes``: (q, floor, gravity in its frame, the toes turned)."""
    from ..model import restrict_configurations

    if np.shape(q)[-1] != h.model.nq:
        q = restrict_configurations(q, full, h)
    q, clamped = inside_ranges(h, q)
    if clamped:
        import warnings

        warnings.warn("the motion to track goes past joint ranges, clamped: " + describe_clamped(
            clamped, len(q)), ReferenceRangeWarning, stacklevel=3)  # fmt: skip
    gravity = np.asarray(h.model.gravity.linear, dtype=float)
    if floor is not None:
        if isinstance(floor, str):
            from .floor import fit_floor

            floor = fit_floor(h, time, q)
        q = floor.onto(h.model, time, q)
        gravity = floor.gravity(gravity)
    turned: dict[str, tuple[int, float]] = {}
    if toes:
        q, turned = toes_on_floor(h, q, None if floor is None else 0.0)
    return q, floor, gravity, turned


def _errors(model, traj, reference: MotionReference, ctl: MotionTracker):
    """(the reference at a run's records, each record's error against it); a failed run's
    message says how it lost the motion (:func:`_lost`)."""
    ref_q = np.array([reference.state(float(x))[0] for x in traj.t])
    err = np.array([pin.difference(model, a, b) for a, b in zip(traj.q, ref_q, strict=True)])
    if traj.status != "completed" and len(err):
        cause = _lost(traj.t, err, ctl)
        if cause:
            traj.metadata["message"] = f"{traj.metadata.get('message', 'failed')}; {cause}"
    return ref_q, err


# [m] how far under its stances a reference's floor goes to keep its filtered feet out of it
FLOOR_DIP = 0.005


def reference_floor(h, q) -> float:
    """The height of the floor under a filtered motion ``q`` followed without a fitted floor:
    its lowest sole point (a filtered stance dips a few millimetres at an impact: the floor is
    under the dips, so that the reference never drives a foot into it), but at most
    :data:`FLOOR_DIP` under its stances (the median of the lowest sole point,
    :func:`~humanoid.motion.coordinates.motion_floor`): deeper is an outlier (a noisy frame, a
    rigid foot's tip at push-off, a filter's end) over which the stances would float."""
    low = lowest_sole_points(h, q)
    return max(float(low.min()), float(np.median(low)) - FLOOR_DIP)


# a run whose pelvis is this far from the motion's [m, deg] has lost it (the cause of a fall)
LOST_POSITION, LOST_ANGLE = 0.10, 15.0


def lost_at(err: np.ndarray) -> int | None:
    """The first record at which a run's pelvis is over :data:`LOST_POSITION` or
    :data:`LOST_ANGLE` from its motion's (``err``: :attr:`Tracked.joint_error`), or None."""
    off = (np.linalg.norm(err[:, :3], axis=1) > LOST_POSITION) | (
        np.degrees(np.linalg.norm(err[:, 3:6], axis=1)) > LOST_ANGLE)  # fmt: skip
    return int(np.argmax(off)) if off.any() else None


def _lost(times, err: np.ndarray, ctl: MotionTracker) -> str:
    """Why a run fell: when it lost the motion (its pelvis first over :data:`LOST_POSITION`
    or :data:`LOST_ANGLE` from the motion's) and how, and what the feet were doing then."""
    i = lost_at(err)
    if i is None:
        return ""
    t = float(times[i])
    dx, dy = err[i, 0], err[i, 1]  # the motion's pelvis from the run's, in the run's axes
    where = [f"{abs(dx) * 100:.0f} cm {'behind' if dx > 0 else 'ahead of'} it",
             f"{abs(dy) * 100:.0f} cm to its {'right' if dy > 0 else 'left'}"]  # fmt: skip
    feet = [s for s in SIDES if ctl.in_contact(s, t)]
    stance = {0: "in flight", 1: f"on the {feet[0]} foot" if feet else "", 2: "on both feet"}
    return (f"it lost the motion at t = {t:.2f} s, {stance[len(feet)]}: the pelvis "
            f"{', '.join(where)}, turned {np.degrees(np.linalg.norm(err[i, 3:6])):.0f} deg from "
            "it")  # fmt: skip
