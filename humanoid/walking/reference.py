"""A person's gait cycle, fitted to a body: the reference the walking controller tracks.

The gait lab's normative angles (:mod:`humanoid.walking.norms`, at the walk's dimensionless
speed) are fitted, one instant of the cycle at a time, to the body's own segments, under the
constraints a walking foot obeys:

- **Stance** (heel strike to foot off, each foot at its footstep): the foot rolls over its heel,
  lies flat, then rolls over its toes. Its pitch is prescribed: from the pitch at heel strike
  (what the normative angles give) smoothly to flat at the end of the loading response, flat
  until heel off, then smoothly to the pitch at foot off; the heel edge's or toe edge's middle
  stays where it touched the ground. The pose of a stance foot is a constraint.
- **Swing**: a first fit leaves the swing foot where the normative angles carry it; that path
  is then bent, smoothly, to leave from the foot-off pose and land on the next heel-strike pose,
  raised where a corner of the sole would be lower than ``CLEARANCE sin(pi u)`` (u from 0 at
  foot off to 1 at heel strike), and a second fit makes it a constraint.
- **Everything else** is a least-squares fit (Gauss-Newton on the configuration's Lie group,
  numerical Jacobians): the pelvis angles, the hip, knee and ankle angles of both sides against
  the norms (:mod:`humanoid.walking.clinical`); the pelvis's sideways sway, that of a linear
  inverted pendulum whose zero-moment point is on the stance foot (:func:`lateral_sway`), and
  its rise and fall (2.5 cm amplitude, lowest as the loading response ends); the trunk upright
  and facing forward; every other joint near the standing posture. (Arm swing: not yet.)

Foot placement: steps of the length a person chooses at the speed
(:func:`~humanoid.walking.norms.choose_gait`), the feet a walking base apart, pointing forward.
The cycle starts at the right heel strike; one cycle is a stride (two steps).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
import pinocchio as pin

from ..errors import HumanoidError
from ..model import SIDES
from .clinical import ANGLES, leg_chains, torso_frame
from .norms import choose_gait, free_speed, norms
from .plan import smooth_step

__all__ = [
    "CenterOfMassPlan",
    "GaitCycle",
    "fit_cycle",
    "lateral_sway",
    "leg_length",
    "periodic_pendulum",
    "plan_com",
]

FRAMES = 50  # instants per cycle (the norms' 2 % steps)
W_FOOT = 1e3  # weight of a constrained foot pose (per m and per rad)
W_ANGLE = 1.0  # per rad of a normative angle
W_TRUNK = 1.0  # per rad of the thorax's tilt and turn
W_POSTURE = 0.1  # per rad from the standing posture, every joint
W_PELVIS = 20.0  # per m of the pelvis from its lateral and vertical path
PELVIS_BOB = 0.025  # [m] amplitude of the pelvis's rise and fall (people's CoM: 3-5 cm p-p)
COM_BOB = 0.0175  # [m] amplitude of the planned centre of mass's rise and fall (3.5 cm p-p)
COP_START, COP_END = 0.1, 0.9  # the centre of pressure's run, heel to toe edge, over a stance
CLEARANCE = 0.01  # [m] the swing foot's lowest corner this far above the floor in mid-swing


def leg_length(h) -> float:
    """The standing height of the hips [m] (the leg length that makes gaits comparable)."""
    data = h.model.createData()
    pin.framesForwardKinematics(h.model, data, h.standing_configuration())
    chains = leg_chains(h)
    return float(np.mean([data.oMi[chains[s].joints[0]].translation[2] for s in SIDES]))


@dataclass
class GaitCycle:
    """One stride of a body's walk: configurations over the cycle and where the feet are.

    Attributes:
        phase: (N,) fractions of the cycle (from the right heel strike).
        q: (N, nq) configurations; the cycle repeats shifted by ``stride`` along x.
        gait: the chosen speed, step length, cadence and events (see ``choose_gait``).
        feet: for each side, the (N, 6) poses of its sole (x, y, z, roll, pitch, yaw).
        contact: for each side, (N,) its contact phase (0 swing, 1 heel, 2 flat, 3 toe).
        residual: largest residual of a stance foot's pose in the fit [m or rad].
        com: a dynamically consistent plan of the centre of mass for the walk's footsteps
            (:func:`plan_com`), at the cycle's mean height, for a controller to track.
    """

    phase: np.ndarray
    q: np.ndarray
    gait: dict
    feet: dict
    contact: dict
    residual: float
    com: CenterOfMassPlan

    @property
    def period(self) -> float:
        return self.gait["cycle"]

    @property
    def stride(self) -> float:
        return 2.0 * self.gait["step_length"]


class _Fitter:
    """The per-instant fit (see the module docstring)."""

    def __init__(self, h, gait: dict) -> None:
        self.model = h.model
        self.data = h.model.createData()
        self.chains = leg_chains(h)
        self.q0 = h.standing_configuration()
        v_hat = gait["dimensionless_speed"]
        n = norms()
        self.pct = n.percent / 100.0
        self.curves = {name: n.curve(name, v_hat)[0] for name in ANGLES}
        # the lab's pelvis is tilted forward by its marker set (about 11 deg; the body's pelvis
        # is level when it stands): keep the tilt's motion, and the thigh's angle to the room
        offset = float(self.curves["pelvis_tilt"].mean())
        self.curves["pelvis_tilt"] = self.curves["pelvis_tilt"] - offset
        self.curves["hip_flexion"] = self.curves["hip_flexion"] - offset
        self.sole = {s: self.chains[s].sole for s in SIDES}
        # the sole's contact points, and its heel and toe edges' middles, in the sole frame
        self.corners = {s: h.sole_points(s) for s in SIDES}
        self.edge = {}
        for s, pts in self.corners.items():
            order = np.argsort(pts[:, 0])
            self.edge[s] = (pts[order[:2]].mean(axis=0), pts[order[2:]].mean(axis=0))
        self.thorax = torso_frame(self.model)
        self.pelvis_target = None

    def norm(self, name: str, psi: float) -> float:
        """A normative angle [deg] at a side's phase psi (periodic)."""
        return float(np.interp(psi % 1.0, self.pct, self.curves[name]))

    def angles(self, psi: float) -> np.ndarray:
        """The normative side angles in clinical.ANGLES order at the side's phase."""
        return np.array([self.norm(k, psi) for k in ANGLES])

    # -- the residual ----------------------------------------------------------------------
    def wants(self, phi: float) -> tuple[dict, tuple | None]:
        """What the fit aims at, at the cycle's phase phi: each side's normative angles [deg],
        and the pelvis's (y, z or None) [m] if it has a path."""
        angles = {s: self.angles(phi + (0.5 if s == "left" else 0.0)) for s in SIDES}
        return angles, None if self.pelvis_target is None else self.pelvis_target(phi)

    def residual(self, q, targets: dict, wants: tuple) -> np.ndarray:
        model, data = self.model, self.data
        pin.framesForwardKinematics(model, data, q)
        r = []
        for s, target in targets.items():
            err = target.actInv(data.oMf[self.sole[s]])
            r.append(W_FOOT * pin.log6(err).vector)
        angles, pelvis = wants
        for s in SIDES:
            a, want = self.chains[s].angles(data), angles[s]
            # the pelvis is shared: each side fits its own view of it at half weight
            r.append(W_ANGLE * math.sqrt(0.5) * np.radians(a[:3] - want[:3]))
            r.append(W_ANGLE * np.radians(a[3:] - want[3:]))
        if pelvis is not None:  # lateral sway and rise and fall, of the pelvis
            c = data.oMi[1].translation
            r.append(
                W_PELVIS
                * np.array([c[1] - pelvis[0], 0.0 if pelvis[1] is None else c[2] - pelvis[1]])
            )
        if self.thorax is not None:
            R = data.oMf[self.thorax].rotation
            r.append(W_TRUNK * pin.log3(R))
        d = pin.difference(model, self.q0, q)
        r.append(W_POSTURE * d[6:])

        return np.concatenate([np.ravel(x) for x in r])

    def solve(self, q, phi: float, targets: dict, iterations: int = 30) -> np.ndarray:
        """Gauss-Newton with a small damping, numerical Jacobian on the tangent space."""
        model = self.model
        eps = 1e-7
        wants = self.wants(phi)
        for _ in range(iterations):
            r = self.residual(q, targets, wants)
            J = np.empty((len(r), model.nv))
            for i in range(model.nv):
                dq = np.zeros(model.nv)
                dq[i] = eps
                J[:, i] = (self.residual(pin.integrate(model, q, dq), targets, wants) - r) / eps
            step = np.linalg.solve(J.T @ J + 1e-8 * np.eye(model.nv), -J.T @ r)
            q = pin.integrate(model, q, step)
            if np.abs(step).max() < 1e-7:
                break
        return q


def periodic_pendulum(p: np.ndarray, omega2, dt: float) -> np.ndarray:
    """The periodic path of an inverted pendulum's mass over a periodic zero-moment point:
    c'' = omega2 (c - p) on a closed loop of ``len(p)`` samples ``dt`` apart (central
    differences). ``omega2`` [1/s^2], a number or one per sample, is (g + z'') / z for a mass at
    height z above the floor: the cart-table relation p = c - z c'' / (g + z'')."""
    n = len(p)
    w2 = np.broadcast_to(np.asarray(omega2, dtype=float), (n,))
    D2 = (np.roll(np.eye(n), 1, axis=1) - 2 * np.eye(n) + np.roll(np.eye(n), -1, axis=1)) / dt**2
    return np.linalg.solve(D2 - np.diag(w2), -w2 * np.asarray(p, dtype=float))


def periodic_derivative(x: np.ndarray, dt: float) -> np.ndarray:
    """Central difference of a periodic sampled signal along axis 0."""
    return (np.roll(x, -1, axis=0) - np.roll(x, 1, axis=0)) / (2 * dt)


@dataclass
class CenterOfMassPlan:
    """The centre of mass over one stride, planned to be a person's (dynamically consistent).

    Vertically, it rises and falls ``COM_BOB`` about its mean, twice a stride, lowest in the
    middle of each double support: the floor then pushes 1 + COM_BOB (4 pi / T)^2 / g body
    weights at its lowest and 1 - that at its highest (T the stride's period). Across and
    along, it is the periodic path of an inverted pendulum on that height (``periodic_pendulum``)
    whose zero-moment point is each stance foot's centre of pressure, rolling from near the heel
    at heel strike to the forefoot at foot off, and passed from the trailing foot to the leading
    one over each double support.

    Attributes:
        phase: (n,) fractions of the stride. c, dc, ddc: (n, 3) the centre of mass [m], its
        velocity [m/s] and acceleration [m/s^2] on the first lap (x grows one stride a lap).
        zmp: (n, 2) the planned zero-moment point. stride: [m]. period: [s].
    """

    phase: np.ndarray
    c: np.ndarray
    dc: np.ndarray
    ddc: np.ndarray
    zmp: np.ndarray
    stride: float
    period: float

    def at(self, phi: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """(c, dc, ddc) at the cycle's phase phi (any real number: laps add strides)."""
        lap = math.floor(phi)
        u = phi - lap
        # x less its steady progress is periodic (interpolating x itself across the lap's end
        # would blend in the first sample, a stride behind)
        c = self.c - np.outer(self.phase, [self.stride, 0.0, 0.0])
        out = [
            np.array([np.interp(u, self.phase, x[:, i], period=1.0) for i in range(3)])
            for x in (c, self.dc, self.ddc)
        ]
        out[0][0] += self.stride * phi
        return out[0], out[1], out[2]


def plan_com(gait: dict, feet: dict, z_mean: float, g: float = 9.81,
             samples: int = 400) -> CenterOfMassPlan:  # fmt: skip
    """Plan the centre of mass over a stride (see :class:`CenterOfMassPlan`).

    Args:
        gait: the walk's events (``choose_gait``, with ``width`` set). feet: for each side,
            ``(x0, y, heel, toe)``: the x of its sole frame's origin on footstep 0 and the y of
            its centre line [m], and its heel and toe edges' x in the sole frame [m].
        z_mean: the centre of mass's mean height [m].
    """
    T, L = gait["cycle"], gait["step_length"]
    off, ds = gait["foot_off"], gait["opposite_foot_off"]
    phase = np.arange(samples) / samples
    dt = T / samples

    def cop(side: str, phi: float) -> tuple[np.ndarray | None, float]:
        """The side's centre of pressure at the cycle's phase, and its phase in its stance."""
        psi_raw = phi + (0.5 if side == "left" else 0.0)
        k = math.floor(psi_raw)
        psi = psi_raw - k
        if psi >= off:
            return None, psi
        x0, y, heel, toe = feet[side]
        u = COP_START + (COP_END - COP_START) * psi / off
        return np.array([x0 + 2 * L * k + heel + u * (toe - heel), y]), psi

    zmp = np.zeros((samples, 2))
    for i, phi in enumerate(phase):
        (pr, psi_r), (pl, psi_l) = cop("right", phi), cop("left", phi)
        if pr is not None and pl is not None:  # double support: from the trailing foot
            lead, trail, psi = (pr, pl, psi_r) if psi_r < psi_l else (pl, pr, psi_l)
            w = float(smooth_step(psi / ds))
            zmp[i] = (1 - w) * trail + w * lead
        else:
            zmp[i] = pr if pr is not None else pl
    w_z = 4 * math.pi / T
    arg = w_z * T * (phase - ds / 2)
    z = z_mean - COM_BOB * np.cos(arg)
    dz = COM_BOB * w_z * np.sin(arg)
    ddz = COM_BOB * w_z**2 * np.cos(arg)
    omega2 = (g + ddz) / z
    v = 2 * L / T
    x = v * T * phase + periodic_pendulum(zmp[:, 0] - v * T * phase, omega2, dt)
    y = periodic_pendulum(zmp[:, 1], omega2, dt)
    dx = v + periodic_derivative(x - v * T * phase, dt)
    c = np.stack([x, y, z], axis=1)
    dc = np.stack([dx, periodic_derivative(y, dt), dz], axis=1)
    ddc = np.stack([omega2 * (x - zmp[:, 0]), omega2 * (y - zmp[:, 1]), ddz], axis=1)
    return CenterOfMassPlan(phase, c, dc, ddc, zmp, 2 * L, T)


def lateral_sway(
    phase: np.ndarray, period: float, width: float, height: float, double_support: float
) -> np.ndarray:
    """The periodic lateral path of a linear inverted pendulum of ``height`` [m] whose zero-moment
    point sits on the stance foot's centre line (-width/2 on the right foot from the right heel
    strike, +width/2 on the left from half a cycle on; it moves across during each double
    support, which lasts ``double_support / 2`` from each heel strike), on the phase grid."""
    psi = phase % 1.0

    def zmp(x):  # from the left foot to the right during the double support from 0, and back
        half = double_support / 2
        if x < half:
            return width / 2 - width * float(smooth_step(x / half))
        if x < 0.5:
            return -width / 2
        if x < 0.5 + half:
            return -width / 2 + width * float(smooth_step((x - 0.5) / half))
        return width / 2

    p = np.array([zmp(x) for x in psi])
    return periodic_pendulum(p, 9.81 / height, period / len(phase))


def fit_cycle(h, speed: float | None = None, width: float | None = None,
              frames: int = FRAMES) -> GaitCycle:  # fmt: skip
    """Fit one stride of a person's gait to ``h`` (see the module docstring).

    Args:
        h: The humanoid (a free-flyer root, two legs with feet that have contact points).
        speed: Walking speed [m/s]; default the body's free speed (``norms.free_speed``).
        width: Distance between the feet's centre lines [m]; default the foot's width plus 3 %
            of the leg length (a person's walking base), at most the standing stance.
        frames: Instants per cycle.
    """
    ell = leg_length(h)
    speed = free_speed(ell) if speed is None else float(speed)
    if not 0.3 <= speed <= 2.5:
        raise HumanoidError(f"speed must be in [0.3, 2.5] m/s, got {speed}")
    gait = choose_gait(speed, ell)
    fitter = _Fitter(h, gait)
    data, model = fitter.data, h.model
    pin.framesForwardKinematics(model, data, fitter.q0)
    soles0 = {s: data.oMf[fitter.sole[s]].copy() for s in SIDES}
    if width is None:
        foot_width = float(np.ptp(fitter.corners["left"][:, 1]))
        width = min(abs(soles0["left"].translation[1] - soles0["right"].translation[1]),
                    0.03 * ell + foot_width)  # fmt: skip
    L, off, flat = gait["step_length"], gait["foot_off"], gait["opposite_foot_off"]
    heel_off = 0.65 * off
    phase = np.arange(frames) / frames

    def step_pose(side: str, k: int) -> pin.SE3:
        """The flat pose of a side's k-th footstep (right k = 0 at x = 0, left k = 0 at -L)."""
        x = 2 * L * k - (L if side == "left" else 0.0)
        y = width / 2 if side == "left" else -width / 2
        return pin.SE3(np.eye(3), np.array([x + soles0[side].translation[0], y, 0.0]))

    # foot pitch at heel strike and at foot off, from the normative angles: the foot against the
    # floor = ankle + hip - pelvis tilt - knee (sagittal chain, degrees; toes up positive)
    def foot_pitch(psi):
        a = fitter.angles(psi)
        return math.radians(a[7] + a[3] - a[0] - a[6])

    pitch_strike, pitch_off = foot_pitch(0.0), foot_pitch(off)
    z_com0 = pin.centerOfMass(model, data, fitter.q0)[2]
    sway = lateral_sway(phase, gait["cycle"], width, z_com0, gait["double_support"])
    fitter.pelvis_target = lambda phi: (float(np.interp(phi % 1.0, phase, sway, period=1.0)), None)

    def stance_target(side, psi, k) -> tuple[pin.SE3, int]:
        """Pose of a stance foot at its phase psi (< off), on footstep k."""
        base = step_pose(side, k)
        heel, toe = fitter.edge[side]
        if psi < flat:
            theta, pivot, kind = pitch_strike * (1 - smooth_step(psi / flat)), heel, 1
        elif psi < heel_off:
            return base, 2
        else:
            theta = pitch_off * smooth_step((psi - heel_off) / (off - heel_off))
            pivot, kind = toe, 3
        # rotate about the pivot edge (toes up positive: a rotation about -y)
        R = pin.utils.rotate("y", -theta)
        p = base.translation + base.rotation @ pivot
        return pin.SE3(R, p - R @ pivot), kind

    def targets_at(phi, swing_paths=None):
        targets, kinds = {}, {}
        for side in SIDES:
            psi_raw = phi + (0.5 if side == "left" else 0.0)
            k = int(math.floor(psi_raw))  # footstep index of the current stance
            psi = psi_raw - k
            if psi < off:
                targets[side], kinds[side] = stance_target(side, psi, k)
            else:
                kinds[side] = 0
                if swing_paths is not None:
                    targets[side] = swing_paths[side](phi)
        return targets, kinds

    # pass 1: stance feet only; the swing foot goes where the normative angles carry it
    q = fitter.q0.copy()
    qs1, free = [], {s: [] for s in SIDES}
    back = pin.SE3(np.eye(3), np.array([-2 * L, 0.0, 0.0]))  # one stride back
    for phi in phase + 1.0:  # the second lap (footsteps k = 1, 2), from the standing posture
        targets, _ = targets_at(phi)
        q = fitter.solve(q, phi, targets, iterations=100 if phi == 1.0 else 30)
        qs1.append(q.copy())
        pin.framesForwardKinematics(model, data, q)
        for s in SIDES:
            free[s].append(back * data.oMf[fitter.sole[s]])
    # bend each swing path to leave from the foot-off pose and land on the heel-strike pose
    paths = {}
    for s in SIDES:
        shift = 0.5 if s == "left" else 0.0
        i_off = int(round(((off - shift) % 1.0) * frames)) % frames
        i_on = int(round(((1.0 - shift) % 1.0) * frames)) % frames
        start, _ = stance_target(s, off - 1e-9, 0)
        end, _ = stance_target(s, 0.0, 1)
        a0, a1 = free[s][i_off], free[s][i_on]
        if i_on < i_off:  # the free path's landing instant is in the next lap
            a1 = pin.SE3(np.eye(3), np.array([2 * L, 0.0, 0.0])) * a1
        dp0, dp1 = start.translation - a0.translation, end.translation - a1.translation
        dr0 = pin.log3(a0.rotation.T @ start.rotation)
        dr1 = pin.log3(a1.rotation.T @ end.rotation)

        def path(phi, s=s, shift=shift, dp0=dp0, dp1=dp1, dr0=dr0, dr1=dr1):
            psi_raw = phi + shift
            k = int(math.floor(psi_raw))  # the footstep the foot left
            u = (psi_raw - k - off) / (1.0 - off)  # 0 at foot off, 1 at heel strike
            i = int(round((phi % 1.0) * frames)) % frames
            M = free[s][i]
            w = float(smooth_step(u))
            p = M.translation + (1 - w) * dp0 + w * dp1
            p[0] += 2 * L * k
            R = M.rotation @ pin.exp3((1 - w) * dr0 + w * dr1)
            # above the floor: the lowest corner at least CLEARANCE up in mid-swing
            lowest = min((R @ c + p)[2] for c in fitter.corners[s])
            p[2] += max(0.0, CLEARANCE * math.sin(math.pi * min(max(u, 0.0), 1.0)) - lowest)
            return pin.SE3(R, p)

        paths[s] = path
    # pass 2: both feet constrained; the pelvis rises and falls about its mean height in the
    # first pass, lowest at the end of each loading response (the opposite foot's lift-off)
    pelvis1 = np.array([qk[:3] for qk in qs1])
    z_mean, mid_ds = float(pelvis1[:, 2].mean()), gait["opposite_foot_off"]

    def pelvis_target(phi):
        y = float(np.interp(phi % 1.0, phase, sway, period=1.0))
        return y, z_mean - PELVIS_BOB * math.cos(4 * math.pi * (phi - mid_ds))

    fitter.pelvis_target = pelvis_target
    qs, feet, contact, worst = [], {s: [] for s in SIDES}, {s: [] for s in SIDES}, 0.0
    q = qs1[0].copy()
    for phi in phase:
        targets, kinds = targets_at(phi, paths)
        q = fitter.solve(q, phi, targets)
        pin.framesForwardKinematics(model, data, q)
        for s in SIDES:
            M = data.oMf[fitter.sole[s]]
            if kinds[s]:  # a stance foot's pose is a constraint
                worst = max(worst, float(np.abs(pin.log6(targets[s].actInv(M)).vector).max()))
            feet[s].append(np.concatenate([M.translation, pin.rpy.matrixToRpy(M.rotation)]))
            contact[s].append(kinds[s])
        qs.append(q.copy())
    gait = gait | {"width": width, "heel_off": heel_off}
    feet_plan = {
        s: (
            float(soles0[s].translation[0]) - (L if s == "left" else 0.0),
            width / 2 if s == "left" else -width / 2,
            float(fitter.edge[s][0][0]),
            float(fitter.edge[s][1][0]),
        )  # fmt: skip
        for s in SIDES
    }
    z_mean_com = float(np.mean([pin.centerOfMass(model, data, qk)[2] for qk in qs]))
    return GaitCycle(
        phase=phase,
        q=np.array(qs),
        gait=gait,
        feet={s: np.array(v) for s, v in feet.items()},
        contact={s: np.array(v) for s, v in contact.items()},
        residual=worst,
        com=plan_com(gait, feet_plan, z_mean_com),
    )
