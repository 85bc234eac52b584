"""A person's walk on the rigid ground: the fitted gait cycle tracked by a whole-body controller.

The reference is a body's own gait cycle (:func:`~humanoid.walking.reference.fit_cycle`): the
normative angles of a gait lab fitted to its segments, heel strike to toe off. The plant is the
ground contact of :mod:`humanoid.constraints.ground` (every sole point a unilateral contact with
Coulomb friction, solved at the velocity level each step) and the joint ranges as constraints of
the same solve. Between them, at every step, a task-space inverse-dynamics QP (ProxQP) finds the
generalised acceleration dv and the forces f of the sole points that carry load, and only the
joint torques tau = (M dv + h - J^T f)[6:] leave it:

- **Equalities.** The free flyer's six rows of the dynamics (it is never actuated). Each sole
  point within ``touch`` (1 cm) of the floor that the cycle's contact phase says is loaded (the
  heel's points from heel strike, all of them from foot flat, the toe's from heel off) sticks:
  J (v + T dv) + gap = 0, its velocity brought to rest over ``contact_time`` T (20 ms; a point
  still above the floor settles onto it over ``settle``: with a 2 mm reach a flat foot's toes
  hovered a few millimetres up all of mid-stance and the heel carried the whole load, its
  pitch about the heel left to round-off). The plant resolves the impacts; the
  controller does not command them. (With T = H = dt, touch = 0.2 mm and no settling, the QP
  is the plant's own velocity-level rule and the two agree to 1e-5: a test.)
- **Inequalities.** Those points' forces inside the friction cone (a pyramid, at a smaller
  friction coefficient than the floor's); every other sole point near the floor does not go
  through it within the ``horizon`` H (J_n (v + H dv) + depth / H >= 0, no force: 20 ms, so a
  toe descending fast is slowed over it, not stopped within one step); joint ranges as
  velocity dampers over the same horizon. When no point satisfies them all, the step is solved
  once more with the dynamics and the loaded points only (the plant enforces the floor and the
  ranges; ``relaxed`` counts such steps).
- **Costs.** The swing foot's pose: the cycle's own swing, carried from the footstep it left to
  the next one (moved where the balance feedback says), its error at lift-off fading out along
  a quintic, raised in mid-swing and aimed a little into the floor at the end, so that it lands
  whatever the timing; a foot that should bear load and does not touch yet reaches for the
  floor; a bearing foot's sticking points hold it, and its task only keeps it from rolling over
  its sides (and flat, strongly, once the cycle says flat). The centre of mass on the cycle's
  dynamically consistent plan (:class:`~humanoid.walking.reference.CenterOfMassPlan`: a
  pendulum over a centre of pressure that rolls heel to toe), which the fitted kinematics
  follow too; its feedback's horizontal acceleration is one the feet can carry (the centre of
  pressure it implies is moved into the loaded soles' hull); optionally (``w_share``), across
  a double support, the vertical load split between the feet as the plan splits it. The
  pelvis and trunk (any humanoid's: the frame its arms hang from) upright,
  facing the way the feet point. The joints' angles (the cycle's, at a low weight), and small
  forces.
- **Timing.** The cycle's clock, except that a trailing foot stays on its toes past its foot
  off (at most ``late_lift`` of a cycle) until the other foot touches: the body is never
  launched into the air by a late landing.

**Balance** is kept the way people keep it, by where the feet land: the divergent component of
motion xi = c + c'/omega (the capture point) is compared with the cycle's, and the landing foot
is moved by that error (Hof 2008's "constant offset" control), and by half as much again
along the walk when the body is behind its plan: a body that falls behind stalls over its
straight stance leg unless its next step is shorter. Each footstep then re-anchors
the reference: the cycle is followed relative to the footholds the body actually has, not to a
fixed place in the world, so its errors never accumulate.

**Curves** (``radius``): each footstep's anchor is the one before's turned about the circle's
centre by the arc between them (:func:`bend`), so every point of the straight cycle lands on
the circle, facing along it; the pelvis, trunk and centre of mass take the anchor bent to
where the centre of mass is, and the centre of mass runs on a circle inside the feet's by
v^2 / (R omega^2) with the centripetal acceleration in its plan (the pressure centre that
turns it is then the straight walk's). The swing foot's feed-forward carries the turn of its
anchor.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import numpy as np
import pinocchio as pin
from scipy.interpolate import CubicSpline

from ..constraints.limits import JointRanges
from ..control.qp import WarmQP, checked, contact_qp, dynamics_terms, feet_contacts
from ..control.tasks import (
    CentreOfMassTask,
    ForceTask,
    FrameTask,
    OrientationTask,
    PostureTask,
    TaskStack,
)
from ..effects import Effect
from ..linalg import cross
from ..model import OTHER_SIDE as OTHER
from ..model import SIDES
from .clinical import ANGLES, arm_chains, leg_chains, leg_joint_weights, torso_frame
from .plan import smooth_step

__all__ = ["CyclePlayer", "GaitController", "TrackingGains", "bend"]

# The walk itself, and its analysis: :mod:`humanoid.walking.gait` (``humanoid walk --gait human``).

LWA = pin.ReferenceFrame.LOCAL_WORLD_ALIGNED
RANGE_MARGIN = 0.2  # [rad] joint-range rows this close to a limit enter the QP
RANGE_TIME = 0.05  # [s] the range dampers' time constant
SOLE_DEPTH = 2e-3  # [m] points of a foot's geometry this far above its sole may bear load
FLAT_REACH = 0.04  # [m] a foot kept flat (a start's, a stop's) loads its points this close
REACH = 5e-3  # [m] a foot that should bear and does not touch aims this far into the floor
LIFT = 0.03  # [m] the swing foot is raised this much above the cycle's path in mid-swing (the
# cycle clears the floor by 1 cm there, as people do; the tracking is not that precise)


class CyclePlayer:
    """The fitted cycle as a smooth function of time: the configuration, velocity and
    acceleration of the reference at any t (the cycle repeats, one stride further each lap).

    A periodic cubic spline runs through the cycle's configurations in one chart (tangent
    vectors from the first configuration, the stride's forward motion taken out); velocities
    and accelerations are its central differences on the configuration group.
    """

    def __init__(self, model: pin.Model, cycle, phase0: float = 0.0,
                 hold: tuple[float, float] | None = None) -> None:  # fmt: skip
        self.model, self.cycle = model, cycle
        self.period, self.stride = cycle.period, cycle.stride
        self.phase0 = phase0
        self.hold = hold  # (go, stop): the clock shows phase0 until go, and stands still after
        # stop (None: it runs from t = 0, and before: the reference's velocity at t = 0 is a
        # central difference; clamping it there gave the g1 half its starting speed, and a fall)
        qs = cycle.q.copy()
        qs[:, 0] -= self.stride * cycle.phase
        self.qc = qs[0].copy()
        d = np.array([pin.difference(model, self.qc, q) for q in qs])
        self.spline = CubicSpline(
            np.append(cycle.phase, 1.0), np.vstack([d, d[:1]]), bc_type="periodic"
        )

    def phase(self, t: float) -> float:
        if self.hold is not None:
            go, stop = self.hold
            t = min(max(t, go), stop) - go
        return self.phase0 + t / self.period

    def configuration(self, t: float) -> np.ndarray:
        phi = self.phase(t)
        q = pin.integrate(self.model, self.qc, self.spline(phi % 1.0))
        q[0] += self.stride * phi
        return q

    def state(self, t: float, h: float = 2e-3):
        """(q, v, a) of the reference at t (central differences on the group, O(h^2))."""
        model = self.model
        q0, q, q1 = (self.configuration(t + k * h) for k in (-1, 0, 1))
        back, ahead = pin.difference(model, q0, q), pin.difference(model, q, q1)
        return q, (back + ahead) / (2 * h), (ahead - back) / (h * h)


@dataclass(frozen=True)
class TrackingGains:
    """Gains [1/s^2 for kp, 1/s for kd] and weights of the tracking QP."""

    foot_kp: float = 400.0
    foot_kd: float = 40.0
    com_kp: float = 50.0
    com_kd: float = 14.0
    com_z_kp: float = 100.0
    com_z_kd: float = 20.0
    trunk_kp: float = 100.0
    trunk_kd: float = 20.0
    posture_kp: float = 100.0
    posture_kd: float = 20.0
    w_foot: float = 1.0
    w_stance_foot: float = 0.02  # a loaded foot: its sticking points hold it; it rolls freely
    w_flat: float = 30.0  # a foot the cycle says is flat: its roll and pitch
    w_com: float = 10.0
    w_trunk: float = 3.0
    w_posture: float = 3e-3  # every joint but the legs'
    w_leg_posture: float = 3e-3  # the legs' (their feet, the pelvis and the CoM fix them)
    w_arm_posture: float = 0.03  # the arms' (their swing: at 3e-3 they swung 40-62 degrees)
    w_force: float = 1e-3
    w_share: float = 0.0  # per body weight: a double support's load split as the plan splits
    # it (off: at 10 the male trough rose from 0.52 to 0.72 BW and 0.8 m/s was a person's
    # force, but the 1.95 m body's feet bounced, 6 mm slides; at 100 the trough fell to 0.17)
    mu: float = 0.6
    placement: float = 1.0  # the capture-point error's share moved into the next footstep ...
    placement_behind: float = 1.5  # ... its share along the walk when the body is behind its
    # plan (a shorter step). At 1.0 example-robot-data's human fell in 4 of 12 of its 8-step
    # walks started 1e-6 m/s apart, each about 4.1 s in: a slow step, then a footstep too far
    # ahead of a body that stalled over its straight stance leg; at 1.5 it completed 24 of 24
    # (1e-6 and 1e-4 m/s apart), and fell at 9.6 s of 20 steps (1.5 both ways completed
    # them, but slid the g1's feet 3.2 mm, 1.2 now, and made the male body's stop take an
    # extra step; 1.25 both ways slowed the human to 0.67 m/s of 0.8).
    max_shift: float = 0.15  # [m] largest footstep correction
    touch: float = 1e-2  # [m] a sole point this close to the floor may carry load ...
    settle: float = 0.02  # [s] ... and one above it settles onto the floor in this time
    contact_time: float = 0.02  # [s] a loaded point's velocity reaches its target in this time
    late_lift: float = 0.1  # [cycle] a trailing foot waits at most this long for the other
    heel_rise_margin: float = 0.05  # [rad] a flat foot's heel rises this near the ankle's stop
    horizon: float = 0.02  # [s] free points and joint ranges are kept off their bounds this far
    # ahead: a toe descending at 0.5 m/s 1 cm above the floor is slowed over 20 ms, not stopped
    # within one 1 ms step (which asked 1e4-1e5 rad/s^2 of the joints and made the plant
    # diverge); at 10 ms the female body fell, the male's feet slid 0.9 mm (2.1 at 20 ms)


def ankle_stop(h, chain) -> tuple[int, float, float] | None:
    """(q index, bound, sign) of a leg's ankle hinge and its dorsiflexion stop: the one-DoF
    joint below the knee that pitches the foot most (clinical ankle angle), the bound it
    reaches dorsiflexing, and +1 if dorsiflexion raises q. None without such a joint or bound."""
    model = h.model
    data = model.createData()
    q0 = h.standing_configuration()
    pin.forwardKinematics(model, data, q0)
    pin.updateFramePlacements(model, data)
    a0 = chain.angles(data)[ANGLES.index("ankle_dorsiflexion")]
    best = None
    for j in chain.joints[chain.joints.index(chain.knee) + 1 :]:
        if model.joints[j].nq != 1:
            continue
        q = q0.copy()
        q[model.joints[j].idx_q] += 1e-3
        pin.forwardKinematics(model, data, q)
        pin.updateFramePlacements(model, data)
        rate = chain.angles(data)[ANGLES.index("ankle_dorsiflexion")] - a0  # [deg per mrad]
        if abs(rate) > 0.03 and (best is None or abs(rate) > abs(best[1])):
            best = (j, rate)
    if best is None:
        return None
    iq = model.joints[best[0]].idx_q
    sign = 1.0 if best[1] > 0 else -1.0
    bound = float(model.upperPositionLimit[iq] if sign > 0 else model.lowerPositionLimit[iq])
    return (iq, bound, sign) if np.isfinite(bound) else None


def footstep_phase(side: str, phase: float) -> tuple[int, float]:
    """(footstep index, phase within it, 0 at its heel strike) of a side at the cycle's phase
    (the right heel strikes at whole phases, the left at halves)."""
    psi = phase + (0.5 if side == "left" else 0.0)
    k = math.floor(psi)
    return k, psi - k


def contact_kind(gait: dict, psi: float) -> int:
    """A foot's contact phase at its phase psi within its footstep (see :func:`footstep_phase`):
    0 swing (from foot off), 1 heel (to the other foot's off), 2 flat (to heel off), 3 toe."""
    if psi >= gait["foot_off"]:
        return 0
    if psi < gait["opposite_foot_off"]:
        return 1
    return 2 if psi < gait["heel_off"] else 3


def _apply(anchor: np.ndarray, p: np.ndarray) -> np.ndarray:
    """A point moved by an anchor (x, y, yaw: a rotation about z then a shift)."""
    c, s = math.cos(anchor[2]), math.sin(anchor[2])
    R = np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])
    return R @ p + np.array([anchor[0], anchor[1], 0.0])


def _rot(anchor: np.ndarray) -> np.ndarray:
    return pin.utils.rotate("z", float(anchor[2]))


def _compose(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """The anchor a after b: p -> a(b(p))."""
    c, s = math.cos(a[2]), math.sin(a[2])
    return np.array([a[0] + c * b[0] - s * b[1], a[1] + s * b[0] + c * b[1], a[2] + b[2]])


def bend(anchor: np.ndarray, x: float, radius: float | None, ahead: float) -> np.ndarray:
    """The anchor of the cycle's points ``ahead`` [m] (along x) of a footstep at x that
    ``anchor`` places, when the walk follows a circle of ``radius`` [m] (positive: turning
    left; None: straight): the footstep's anchor turned about the circle's centre (x, radius)
    by ahead / radius, less the ``ahead`` that the arc has already covered. Every cycle point
    (x + ahead, y) then lands on the circle of radius ``radius - y`` at arc length ``ahead``,
    facing along it."""
    if radius is None:
        return anchor
    theta = ahead / radius
    c, s = math.cos(theta), math.sin(theta)
    # the rotation by theta about (x, radius), then the shift back by ``ahead``
    turn = np.array([x - (c * x - s * radius), radius - (s * x + c * radius), theta])
    return _compose(_compose(anchor, turn), np.array([-ahead, 0.0, 0.0]))


class _CyclePlan:
    """What a :class:`GaitController` asks of the body at t: the cycle's clock, the footholds
    (anchored, moved by the balance feedback), the swing foot's path, the contact phases and
    the anchored reference. The controller's QP then makes the body do it."""

    model: Any
    data: Any
    rdata: Any
    ldata: Any
    cycle: Any
    player: CyclePlayer
    ends: Any
    gains: TrackingGains
    radius: float | None
    sole: dict[str, int]
    step_x0: dict[str, float]
    anchors: dict[str, dict[int, np.ndarray]]
    shift: dict[str, np.ndarray]
    lift: dict[str, tuple[int, np.ndarray, np.ndarray, np.ndarray, float]]
    down: dict[str, bool]
    ankle: dict[str, tuple[int, float, float]]
    off: float
    flat: float
    omega: float

    def side_phase(self, side: str, t: float) -> tuple[int, float]:
        """(footstep index, phase within it) of a side at t (0 at its heel strike)."""
        return footstep_phase(side, self.player.phase(t))

    def com_reference(self, t: float) -> tuple:
        """The planned centre of mass (c, dc, ddc) at t, in the cycle's frame."""
        piece = None if self.ends is None else self.ends.piece(t)
        if piece is not None:
            return piece.at(t)
        return self.cycle.com.at(self.player.phase(t))

    def flat_override(self, t: float, steps: dict) -> set:
        """The sides a start or stop keeps flat and bearing whatever the cycle's clock says:
        both feet before the first step and after the last, the braking foot once flat."""
        ends = self.ends
        if ends is None:
            return set()
        if t < ends.t_go or t >= ends.t_stop:
            return set(SIDES)
        side, k = ends.brake
        if t >= ends.stop_from and steps[side][0] >= k:
            return {side}
        return set()

    def contact_kind(self, psi: float) -> int:
        return contact_kind(self.cycle.gait, psi)

    def anchor(self, side: str, k: int) -> np.ndarray:
        return self.anchors[side].get(k, np.zeros(3))

    def step_x(self, side: str, k: int) -> float:
        """The x of a side's footstep k on the cycle's straight line [m]."""
        return self.step_x0[side] + self.cycle.stride * k

    def body_anchor(self, t: float, x: float = 0.0) -> np.ndarray:
        """The anchor of the pelvis and of the centre of mass (at x on the cycle's line): the
        stance foot's (bent along a curve to x); across a double support, from the trailing
        foot's to the leading foot's (starting, the right foot's until the first step lands;
        stopping, the braking foot's from its foot flat)."""
        ends = self.ends
        if ends is not None:
            if t <= ends.time(0.5):  # before the first step lands
                return self.anchor(*ends.start_anchor)
            if t >= ends.stop_from:
                return self.anchor(*ends.brake)
        steps = {s: self.side_phase(s, t) for s in SIDES}
        lead = min(SIDES, key=lambda s: steps[s][1])  # the foot that landed last
        trail = OTHER[lead]

        def placed(side):
            k = steps[side][0]
            x_k = self.step_x(side, k)
            return bend(self.anchor(side, k), x_k, self.radius, x - x_k)

        psi = steps[lead][1]
        a_lead = placed(lead)
        if psi >= self.flat:
            return a_lead
        w = float(smooth_step(psi / self.flat))
        return (1 - w) * placed(trail) + w * a_lead

    def landing(self, side: str, k: int) -> pin.SE3:
        """The pose of a side's sole at its heel strike on footstep k, anchored."""
        shift = 0.5 if side == "left" else 0.0
        t = (k - shift - self.player.phase0) * self.player.period
        q = self.player.configuration(t)
        pin.forwardKinematics(self.model, self.ldata, q)
        M = pin.updateFramePlacement(self.model, self.ldata, self.sole[side])
        a = self.anchor(side, k)
        return pin.SE3(_rot(a) @ M.rotation, _apply(a, M.translation))

    def swing_path(self, side: str, k: int, psi: float, M_now: pin.SE3, v_now: np.ndarray,
                   cycle_pose: tuple):  # fmt: skip
        """The swing foot's pose, spatial velocity and acceleration (world, 6-vectors): the
        cycle's own swing (``cycle_pose``: its pose, velocity and acceleration at this instant,
        unanchored), carried from the anchor of the footstep it left to that of the footstep it
        lands on, and corrected for where the foot really was at lift-off: that error (pose and
        velocity) fades out over the swing along a quintic (the minimum-jerk blend plus the
        Hermite term that carries a velocity). The swing thus keeps the person's foot path,
        knee flexion and clearance (raised LIFT in mid-swing, for the tracking's errors); it is
        aimed REACH into the floor at the end so that it lands whatever the timing. A walk
        that starts in mid-swing starts where the foot is."""
        M_r, v_r, a_r = cycle_pose
        a0, a1 = self.anchor(side, k), self.anchor(side, k + 1)
        u = min(max((psi - self.off) / (1.0 - self.off), 0.0), 1.0)
        if self.lift.get(side, (None,))[0] != k:
            R0 = _rot(a0)
            e_p = M_now.translation - _apply(a0, M_r.translation)
            e_v = v_now[:3] - R0 @ v_r[:3]
            e_R = pin.log3(M_now.rotation @ (R0 @ M_r.rotation).T)
            self.lift[side] = (k, e_p, e_v, e_R, min(u, 0.9))
        _, e_p, e_v, e_R, u0 = self.lift[side]
        D = (1.0 - u0) * (1.0 - self.off) * self.player.period  # the path's duration [s]
        x = (u - u0) / (1.0 - u0)
        dx = 1.0 / D
        s5 = x**3 * (10 - 15 * x + 6 * x * x)
        ds5 = 30 * x * x * (1 - x) ** 2 * dx
        dds5 = 60 * x * (1 - x) * (1 - 2 * x) * dx * dx
        h1 = x - 6 * x**3 + 8 * x**4 - 3 * x**5
        dh1 = (1 - 18 * x * x + 32 * x**3 - 15 * x**4) * dx
        ddh1 = (-36 * x + 96 * x * x - 60 * x**3) * dx * dx
        b = 64 * x**3 * (1 - x) ** 3
        db = 192 * x * x * (1 - x) ** 2 * (1 - 2 * x) * dx
        ddb = 192 * x * (1 - x) * (2 - 10 * x + 10 * x * x) * dx * dx
        up = np.array([0.0, 0.0, LIFT * (1.0 - u0)])
        step = a1 - a0
        a = a0 + s5 * step
        Rz = _rot(a)
        down = np.array([step[0], step[1], -REACH])  # the anchor's shift, and the reach
        reach = np.array([0.0, 0.0, -REACH])
        p = _apply(a, M_r.translation) + (1 - s5) * e_p + D * h1 * e_v + s5 * reach + b * up
        # the anchor turns too (a curve's footsteps differ in yaw): Rz(theta) p_r turns at
        # theta' = s5' dtheta about z; the cycle's point p_r is metres from the origin, so its
        # turn is most of the foot's speed (left out, the feed-forward was off by 2 m/s and
        # every curve fell after a few metres)
        turn = np.array([0.0, 0.0, step[2]])
        Rp, Rv = Rz @ M_r.translation, Rz @ v_r[:3]
        v = Rv + ds5 * down - ds5 * e_p + D * dh1 * e_v + db * up + ds5 * cross(turn, Rp)
        acc = (Rz @ a_r[:3] + dds5 * down - dds5 * e_p + D * ddh1 * e_v + ddb * up
               + dds5 * cross(turn, Rp) + 2 * ds5 * cross(turn, Rv)
               + ds5**2 * cross(turn, cross(turn, Rp)))  # fmt: skip
        E = pin.exp3((1 - s5) * e_R) @ Rz  # R = E R_r: w = E w_r - s5' e_R (+ the anchor's turn)
        R = E @ M_r.rotation
        w_r = E @ v_r[3:]
        spin = pin.exp3((1 - s5) * e_R) @ turn
        w = w_r - ds5 * e_R + ds5 * spin
        dw = (E @ a_r[3:] - dds5 * e_R + ds5 * cross(spin - e_R, w_r) + dds5 * spin
              - ds5**2 * cross(e_R, spin))  # fmt: skip
        return pin.SE3(R, p), np.concatenate([v, w]), np.concatenate([acc, dw])

    # -- the plan at a step -------------------------------------------------------------
    def _reference(self, t: float, q, v) -> tuple:
        """The reference at t, its kinematics left in ``rdata``: (q_r, v_r, the body anchor's
        rotation, the anchored centre of mass plan (c, dc, ddc), the capture point's error)."""
        model, data = self.model, self.data
        nv = model.nv
        q_r, v_r, a_r = self.player.state(t)
        rd = self.rdata
        pin.forwardKinematics(model, rd, q_r, v_r, a_r)
        pin.updateFramePlacements(model, rd)
        c_r, dc_r, ddc_r = self.com_reference(t)
        c = pin.centerOfMass(model, data, q, v, np.zeros(nv))
        dc = data.vcom[0].copy()
        A = self.body_anchor(t, float(c_r[0]))
        R_A = _rot(A)
        if self.radius is not None:  # along a curve, the centre of mass turns with it, on a
            # circle inside the feet's by v^2 / (R omega^2): the pressure centre that turns it
            # is then the straight walk's, between the feet (a person leans into a turn)
            ddc_r = ddc_r + np.array([0.0, dc_r[0] ** 2 / self.radius, 0.0])
            c_r = c_r + np.array([0.0, dc_r[0] ** 2 / (self.radius * self.omega**2), 0.0])
        c_r, dc_r, ddc_r = _apply(A, c_r), R_A @ dc_r, R_A @ ddc_r
        # balance: the capture point's error moves the swing foot's landing
        xi = c[:2] + dc[:2] / self.omega
        xi_r = c_r[:2] + dc_r[:2] / self.omega
        err = xi - xi_r
        return q_r, v_r, R_A, (c_r, dc_r, ddc_r), err

    def _contact_phases(self, t: float, q, near: list, touching: set, side_of: list,
                        phi) -> tuple[dict, dict, set, list]:  # fmt: skip
        """(footstep phases, contact kinds, the sides kept flat, the points near enough to
        bear) of each side at t: the cycle's, overridden by a start's or stop's flat feet, a
        trailing foot that waits for the other one and a heel that rises before its stop."""
        g = self.gains
        steps = {s: self.side_phase(s, t) for s in SIDES}
        kinds = {s: self.contact_kind(steps[s][1]) for s in SIDES}
        flat = self.flat_override(t, steps)
        for s in flat:
            kinds[s] = 2
        if flat:  # a foot kept flat that touches settles its whole sole onto the floor (its
            # toes 1.2 cm up, it stood on its heel for 0.3 s while the body ran over it)
            near = [n or (s in flat and s in touching and d < FLAT_REACH)
                    for n, s, d in zip(near, side_of, phi, strict=True)]  # fmt: skip
        for s in SIDES:  # the trailing foot stays down (on its toes) until the other one lands
            if (kinds[s] == 0 and self.down.get(s, False) and OTHER[s] not in touching
                    and steps[s][1] < self.off + g.late_lift):  # fmt: skip
                kinds[s] = 3
            self.down[s] = kinds[s] != 0
            # a flat foot lets its heel rise when its ankle is about to reach its dorsiflexion
            # stop, as a person's does: else the stop halts the shank and the knee vaults
            if kinds[s] == 2 and s in self.ankle and s not in flat:
                iq, bound, sign = self.ankle[s]
                if sign * (bound - q[iq]) < g.heel_rise_margin:
                    kinds[s] = 3
        return steps, kinds, flat, near

    def _place_footsteps(self, steps: dict, kinds: dict, err: np.ndarray) -> None:
        """Anchor each swinging foot's next footstep: beside the other foot's on the cycle's
        line (bent along a curve), moved by the capture point's error ``err`` [m]."""
        g = self.gains
        for s in SIDES:
            k, psi = steps[s]
            if kinds[s] == 0:  # swing: land the next footstep k + 1 corrected
                k_other = steps[OTHER[s]][0]
                x_other = self.step_x(OTHER[s], k_other)
                base = bend(self.anchor(OTHER[s], k_other), x_other, self.radius,
                            self.step_x(s, k + 1) - x_other)  # fmt: skip
                if psi < 0.85 + 0.15 * self.off:  # frozen in the last part of the swing
                    # a body behind its plan (along the walk's direction at the other foot)
                    # steps shorter by the larger share; a stop's steps (planned to bring the
                    # body to rest) take the one share
                    ahead = _rot(base)[:2, 0]
                    along = float(ahead @ err)
                    stopping = self.ends is not None and (s, k + 1) in self.ends.moved
                    more = 0.0 if stopping or along > 0.0 else g.placement_behind - g.placement
                    shift = g.placement * err + more * along * ahead
                    norm = np.linalg.norm(shift)
                    if norm > g.max_shift:
                        shift *= g.max_shift / norm
                    self.shift[s] = shift
                self.anchors[s][k + 1] = base + np.array([*self.shift[s], 0.0])
                if self.ends is not None:  # a stop's shorter steps
                    back = self.ends.moved.get((s, k + 1), 0.0)
                    self.anchors[s][k + 1][:2] -= (_rot(base) @ [back, 0.0, 0.0])[:2]


class GaitController(_CyclePlan, Effect):
    """Joint torques that walk a body along its fitted gait cycle (see the module docstring).

    Args:
        h: The humanoid. model: the plant's model (with its gravity). cycle: the fitted
            :class:`~humanoid.walking.reference.GaitCycle`. ground: the plant's
            :class:`~humanoid.constraints.ground.ContactSolver`. dt: the step [s].
        phase0: the cycle's phase at t = 0. transitions: a
            :class:`~humanoid.walking.transitions.StartStop`: the walk starts from standing and
            stops standing (its phase0 then replaces ``phase0``).
        radius: the walk follows a circle of this radius [m] (positive: turning left; None: a
            straight line).
    """

    name = "gait"
    velocity_dependent = True

    def __init__(self, h, model, cycle, ground, dt, phase0=0.0, gains=None,
                 transitions=None, radius: float | None = None) -> None:  # fmt: skip
        self.h, self.model, self.cycle = h, model, cycle
        self.radius = radius
        self.data = model.createData()
        self.rdata = model.createData()
        self.ldata = model.createData()  # the landing poses' (not to clobber the reference's)
        self.ends = transitions
        if transitions is None:
            self.player = CyclePlayer(model, cycle, phase0)
        else:
            self.player = CyclePlayer(model, cycle, transitions.phase0, transitions.hold())
        self.ground = ground
        self.dt = dt
        self.gains = gains or TrackingGains()
        self.sole = {s: h.sole_id(s) for s in SIDES}
        self.foot_joint = {s: model.frames[self.sole[s]].parentJoint for s in SIDES}
        pts = {s: h.sole_points(s) for s in SIDES}
        self.sole_middle = {s: float(np.mean(pts[s][:, 0])) for s in SIDES}
        self.tau = np.zeros(model.nv)
        self.weight = h.mass * float(np.linalg.norm(model.gravity.linear))
        self.ranges = JointRanges(h)
        self.pelvis = model.getFrameId(model.names[1], pin.FrameType.JOINT)
        chains = leg_chains(h)
        arms = arm_chains(h, chains)
        self.torso = torso_frame(model, arms.values())
        g = self.cycle.gait
        self.off, self.flat, self.heel_off = g["foot_off"], g["opposite_foot_off"], g["heel_off"]
        # each footstep's x along the cycle's straight line, from its flat stance (footstep 0
        # of the right foot at phase [0, off), of the left at [0.5, 0.5 + off))
        self.step_x0 = {}
        for s in SIDES:
            shift = 0.5 if s == "left" else 0.0
            k = np.floor(cycle.phase + shift)
            flat = cycle.contact[s] == 2
            self.step_x0[s] = float(np.mean(cycle.feet[s][flat, 0] - cycle.stride * k[flat]))
        # anchors: each side's footstep k carries an (x, y, yaw) placement of the cycle's
        self.anchors: dict[str, dict[int, np.ndarray]] = {s: {} for s in SIDES}
        if transitions is not None:  # the standing feet are footsteps 0
            for s in SIDES:
                self.anchors[s][0] = np.array(transitions.anchors[s], dtype=float)
        self.shift = {s: np.zeros(2) for s in SIDES}  # the swing foot's current correction
        # side -> (footstep it left, its pose and velocity errors there, u0)
        self.lift: dict[str, tuple[int, np.ndarray, np.ndarray, np.ndarray, float]] = {}
        # the last solve: (accelerations, contact forces, the loaded points)
        self.last: tuple[np.ndarray, np.ndarray, list[int]] | None = None
        self.relaxed = 0  # steps solved without the range dampers and floor rows
        self.down: dict[str, bool] = {}  # side -> whether it was a stance foot at the last step
        z = pin.centerOfMass(model, self.data, cycle.q[0])[2]
        self.omega = math.sqrt(float(np.linalg.norm(model.gravity.linear)) / z)
        # the legs' joints follow the feet, pelvis and centre of mass (their tasks fix them);
        # the cycle's angles only regularise them
        gains = self.gains
        self.w_posture = leg_joint_weights(model, chains, gains.w_leg_posture, gains.w_posture,
                                           arms, gains.w_arm_posture)  # fmt: skip
        stops = {s: ankle_stop(h, chains[s]) for s in SIDES}
        self.ankle = {s: a for s, a in stops.items() if a is not None}
        self.qp = WarmQP(eps_abs=1e-9, max_iter=1000, primal=1e-7, dual=1e-4)

    def force(self, model, data, t, q, v):
        return self.tau

    def before_step(self, sim, k: int, t: float, q, v) -> None:
        self.update(t, q, v)

    # -- the QP ----------------------------------------------------------------------------
    def update(self, t: float, q, v) -> np.ndarray:
        """The joint torques at t for the state (q, v) (kept in ``tau``; ``last`` keeps the
        solve's accelerations, contact forces and loaded points)."""
        model, data, g, dt = self.model, self.data, self.gains, self.dt
        M, hvec = dynamics_terms(model, data, q, v)
        # contacts: the plant's own detection
        found, side_of = feet_contacts(self.ground, model, data, self.foot_joint, q)
        phi, points = found.phi, found.points
        near = [s is not None and d < g.touch for s, d in zip(side_of, phi, strict=True)]
        touching = {s for s, n in zip(side_of, near, strict=True) if n}
        q_r, v_r, R_A, com_r, err = self._reference(t, q, v)
        steps, kinds, flat, near = self._contact_phases(t, q, near, touching, side_of, phi)
        self._place_footsteps(steps, kinds, err)
        loaded, free, bearing = self._split_contacts(near, kinds, side_of, points)
        tasks = TaskStack(model, data, q, v)
        self._add_foot_tasks(tasks, steps, kinds, bearing, flat)
        support = np.array([points[i][:2] for i in loaded]).reshape(-1, 2)
        self._add_body_tasks(tasks, t, q_r, v_r, R_A, com_r, support)
        forces = [ForceTask(0.0, g.w_force)]
        share = self.load_share(steps, kinds, side_of, loaded) if g.w_share else None
        if share is not None:  # w f_trail - (1 - w) f_lead = 0, the plan's split of the load
            forces.append(ForceTask(0.0, g.w_share, share))
        p = contact_qp(model, data, self.ground, found, loaded, free, tasks, M, hvec, q, v, dt,
                       self.weight, g, self.ranges, RANGE_MARGIN, RANGE_TIME,
                       forces=forces)  # fmt: skip
        return self._solve(p, t, v, M, hvec, loaded)

    def load_share(self, steps, kinds, side_of, loaded) -> np.ndarray | None:
        """In a double support (both feet bearing, the leading one before its foot flat), the
        row over the loaded points' forces (x, y, z each) whose zero splits the vertical load
        as the plan does: the leading foot's share w rises from 0 to 1 along the same smooth
        step as the planned centre of pressure moves from the trailing foot to the leading one
        (:func:`~humanoid.walking.reference.plan_com`), so the trailing leg keeps pushing
        through the double support, as a person's does. None outside a double support."""
        if any(kinds[s] == 0 for s in SIDES):
            return None
        lead = min(SIDES, key=lambda s: steps[s][1])
        psi = steps[lead][1]
        if psi >= self.flat:
            return None
        w = float(smooth_step(psi / self.flat))
        row = np.zeros(3 * len(loaded))
        for j, i in enumerate(loaded):
            row[3 * j + 2] = -(1.0 - w) if side_of[i] == lead else w
        return row

    def _split_contacts(self, near: list, kinds: dict, side_of: list,
                        points: list) -> tuple[list[int], list[int], set[str]]:  # fmt: skip
        """The near points split into loaded (sticking: on the part of the sole that the
        contact phase loads) and free ones, and the sides that bear load."""
        # contacts, split into loaded (sticking) and free points
        loaded: list[int] = []
        free: list[int] = []
        bearing: set[str] = set()
        for i, side in enumerate(side_of):
            ok = False
            if near[i]:
                kind = kinds[side]
                x, _, z = self.data.oMf[self.sole[side]].actInv(points[i])
                x -= self.sole_middle[side]
                # only the sole bears load: a point of the foot's geometry above it (the back
                # of a heel) that nears the floor as the foot pitches is the plant's to stop;
                # made to stick, the erd human's heel pulled its back edge onto the floor and
                # flipped the foot 46 degrees toes up at every heel strike
                ok = z < SOLE_DEPTH and (
                    kind == 2 or (kind == 1 and x < 0) or (kind == 3 and x > 0)
                )
            (loaded if ok else free).append(i)
            if ok:
                bearing.add(side)
        return loaded, free, bearing

    def _add_foot_tasks(self, tasks: TaskStack, steps: dict, kinds: dict, bearing: set,
                        flat: set) -> None:  # fmt: skip
        """The feet's pose tasks: a swinging or reaching foot's, on its path; a bearing
        foot's, only against rolling over its sides (and flat when the cycle says so)."""
        model, data, rd, g = self.model, self.data, self.rdata, self.gains
        # feet: the cycle's pose, on the foot's own anchor (a swing foot moves from the
        # anchor of the step it left to that of the step it lands)
        for s in SIDES:
            k, psi = steps[s]
            fid = self.sole[s]
            M_f = data.oMf[fid]
            M_r = rd.oMf[fid]
            vf_r = pin.getFrameVelocity(model, rd, fid, LWA).vector
            af_r = pin.getFrameClassicalAcceleration(model, rd, fid, LWA).vector
            if kinds[s] == 0:
                vel = pin.getFrameVelocity(model, data, fid, LWA)
                M_ref, v_ref, a_ref = self.swing_path(s, k, psi, M_f, vel.linear,
                                                      (M_r, vf_r, af_r))  # fmt: skip
            else:
                a = self.anchor(s, k)
                Rz = _rot(a)
                M_ref = pin.SE3(Rz @ M_r.rotation, _apply(a, M_r.translation))
                v_ref = np.concatenate([Rz @ vf_r[:3], Rz @ vf_r[3:]])
                a_ref = np.concatenate([Rz @ af_r[:3], Rz @ af_r[3:]])
                if s not in bearing:
                    M_ref.translation[2] -= REACH
                if s in flat:  # kept flat (a start or a stop), pointing its anchor's way
                    M_ref.rotation = Rz
            # a bearing foot's sticking points hold it (it rolls freely); a foot that should
            # bear and does not touch yet reaches for the floor
            if s not in bearing:
                tasks.add(FrameTask(fid, M_ref, g.foot_kp, g.foot_kd, g.w_foot, v_ref, a_ref))
            else:  # it rolls freely over its heel or toes, but not over its sides
                w_pitch = g.w_flat if kinds[s] == 2 else g.w_stance_foot
                w_roll = g.w_flat if kinds[s] == 2 else g.w_foot
                weight = np.array([*[g.w_stance_foot] * 3, w_roll, w_pitch, g.w_foot])
                tasks.add(FrameTask(fid, M_ref, g.foot_kp, g.foot_kd, weight, v_ref, a_ref,
                                    local_angular=True))  # fmt: skip

    def _add_body_tasks(self, tasks: TaskStack, t: float, q_r, v_r, R_A: np.ndarray,
                        com_r: tuple, support: np.ndarray) -> None:  # fmt: skip
        """The centre of mass (its pressure centre kept over ``support``, the loaded points
        (k, 2) [m]), pelvis and trunk, and joint posture tasks."""
        model, g = self.model, self.gains
        c_r, dc_r, ddc_r = com_r
        # centre of mass: the feedback's horizontal acceleration is one the feet can carry (its
        # centre of pressure clipped to the hull of the points that may carry load: a swing
        # foot skimming the floor carries none)
        kp = np.array([g.com_kp, g.com_kp, g.com_z_kp])
        kd = np.array([g.com_kd, g.com_kd, g.com_z_kd])
        tasks.add(CentreOfMassTask(c_r, dc_r, ddc_r, kp, kd, g.w_com, support))
        # pelvis and trunk orientation
        for frame in [self.pelvis] + ([self.torso] if self.torso is not None else []):
            tasks.add(OrientationTask(frame, R_A, g.trunk_kp, g.trunk_kd, g.w_trunk))
        # joints: the cycle's angles
        v_post = v_r.copy()
        if self.ends is not None:  # starting and stopping: lean to the standing posture
            w = self.ends.standing_weight(t)
            if w > 0.0:
                q_r = pin.interpolate(model, q_r, self.ends.q0, w)
                v_post = (1.0 - w) * v_post
        tasks.add(PostureTask(q_r, g.posture_kp, g.posture_kd, self.w_posture, v_post))

    def _solve(self, p, t: float, v, M: np.ndarray, hvec: np.ndarray,
               loaded: list[int]) -> np.ndarray:  # fmt: skip
        """Solve the QP (again without the gap terms, then with the dynamics and the loaded
        points only, when it has no solution) and keep its torques."""
        g, dt = self.gains, self.dt
        x, _ = p.solve(self.qp, relax=False)
        if x is None and loaded:
            # two sticking points of a tilted sole at different depths cannot both close
            # their gaps exactly (the plant's solve resolves that in its own least squares):
            # stick without the gap terms
            p.b[6:] = -(p.U.T @ (p.Jc @ v)) / max(dt, g.contact_time)
            x, _ = p.solve(self.qp, relax=False)
        if x is None:  # the last resort: the dynamics and the loaded points only (no range
            # dampers, no floor rows for the other points: the plant enforces both)
            self.relaxed += 1
            x = p.solve_cones(self.qp)
        self.tau, dv, f = p.torques(checked(x, "walking", t, self.qp), M, hvec, self.weight)
        self.last = (dv, f, [int(i) for i in loaded])
        return self.tau
