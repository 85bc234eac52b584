"""A person's gait cycle, fitted to a body: the reference the walking controller tracks.

The gait lab's normative angles (:mod:`humanoid.walking.norms`, at the walk's dimensionless
speed) are fitted, one instant of the cycle at a time, to the body's own segments, under the
constraints a walking foot obeys:

- **Stance** (heel strike to foot off, each foot at its footstep): the foot rolls over its heel,
  lies flat, then rolls over its toes. Its pitch is prescribed: from the pitch at heel strike
  (what the normative angles give) smoothly to flat at the end of the loading response, flat
  until heel off, then the pitch the normative chain itself gives (hip, knee and ankle against
  the pelvis: 20 degrees at the opposite heel strike, 50 at foot off), eased in over
  ``HEEL_RISE``; the heel edge's or toe edge's middle stays where it touched the ground. The
  pose of a stance foot is a constraint.
- **Swing**: a first fit leaves the swing foot where the normative angles carry it; that path
  is then bent, smoothly, to leave from the foot-off pose and land on the next heel-strike pose,
  raised where a corner of the sole would be lower than ``CLEARANCE sin(pi u)`` (u from 0 at
  foot off to 1 at heel strike), and a second fit makes it a constraint.
- **Everything else** is a least-squares fit (Levenberg-Marquardt on the configuration's Lie
  group, numerical Jacobians): the pelvis angles, the hip, knee and ankle angles of both sides
  against the norms (:mod:`humanoid.walking.clinical`); the centre of mass, across and along,
  on the walk's dynamically consistent plan (:func:`plan_com`: a pendulum over a centre of
  pressure that rolls heel to toe), its height left to the legs; the trunk upright and facing
  forward; the legs' joints near the standing posture, the trunk's and head's more strongly
  (the legs carry the centre of mass); the arms swinging opposite the legs (:func:`arm_swing`);
  every joint inside its range. The fitted kinematics' centre of mass is the plan's to 0.1 mm
  across and along (1.5 cm in height), so a controller that tracks both does not fight itself.

Foot placement: steps of the length a person chooses at the speed
(:func:`~humanoid.walking.norms.choose_gait`), the feet a walking base apart, pointing forward.
The cycle starts at the right heel strike; one cycle is a stride (two steps).
"""

from __future__ import annotations

import functools
import hashlib
import json
import math
import warnings
import zipfile
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import pinocchio as pin

from ..cache import CacheWarning, cache_dir, model_key, sources_key, write_atomic
from ..constraints.limits import JointRanges
from ..errors import WalkError
from ..model import SIDES
from .clinical import ANGLES, arm_chains, leg_chains, leg_joint_weights, torso_frame
from .norms import FREE_DIMENSIONLESS_SPEED, choose_gait, free_speed, norms
from .plan import smooth_step

__all__ = [
    "CenterOfMassPlan",
    "GaitCycle",
    "fit_cycle",
    "leg_length",
    "periodic_pendulum",
    "plan_com",
]

FRAMES = 50  # instants per cycle (the norms' 2 % steps)
W_FOOT = 1e4  # weight of a constrained foot pose (per m and per rad)
W_ANGLE = 1.0  # per rad of a normative angle
W_TRUNK = 1.0  # per rad of the thorax's tilt and turn
W_POSTURE = 0.1  # per rad from the standing posture, a leg's joints
W_RANGE = 1000.0  # per rad beyond a joint's range
W_UPPER = 3.0  # per rad from the standing posture, the trunk's, head's and arms' joints
W_COM = 200.0  # per m of the centre of mass from its plan
COM_BOB = 0.0175  # [m] amplitude of the centre of mass's rise and fall (people: 3-5 cm p-p)
COP_START, COP_END = 0.1, 0.9  # the centre of pressure's run, heel to toe edge, over a stance
HEEL_RISE = 0.05  # [cycle] the heel's rise eases into the norms' foot pitch this fast
CLEARANCE = 0.01  # [m] the swing foot's lowest corner this far above the floor in mid-swing
W_ARM = 30.0  # per rad of the arm swing's shoulder and elbow angles
ARM_ARC = 30.0  # [deg] the shoulder's swing, front to back, at the free dimensionless speed
ELBOW_FLEXION = (15.0, 8.0)  # [deg] the elbow's mean flexion and its swing about it


def arm_swing(psi: float, v_hat: float) -> np.ndarray:
    """The arm swing at a side's phase psi (0 at its own heel strike) and dimensionless speed:
    (shoulder flexion, elbow flexion) [deg] from the hanging arm. Each arm swings opposite its
    leg, most back at its own heel strike, most forward at the other's, over a total arc of
    about 30 degrees at free speed (Perry & Burnfield 2010, ch. 8), growing with the speed
    (scaled with the dimensionless speed, 10-45 degrees); the elbow bends most when the arm is
    forward."""
    arc = float(np.clip(ARM_ARC * v_hat / FREE_DIMENSIONLESS_SPEED, 10.0, 45.0))
    c = -math.cos(2 * math.pi * psi)
    return np.array([0.5 * arc * c, ELBOW_FLEXION[0] + ELBOW_FLEXION[1] * c])


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
        com: the centre of mass's plan, which the fit follows.
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
        self.q0 = h.reference_configuration()  # a robot's own, e.g. half sitting
        v_hat = gait["dimensionless_speed"]
        self.v_hat = v_hat
        self.arms = arm_chains(h, self.chains)
        n = norms()
        self.pct = n.percent / 100.0
        # the body's pelvis is level when it stands; the lab's tilts forward (Norms.curve)
        self.curves = {name: n.curve(name, v_hat, pelvis="level")[0] for name in ANGLES}
        self.sole = {s: self.chains[s].sole for s in SIDES}
        # the sole's contact points, and its heel and toe edges' middles, in the sole frame
        self.corners = {s: h.sole_points(s) for s in SIDES}
        self.edge = {}
        for s, pts in self.corners.items():
            order = np.argsort(pts[:, 0])
            self.edge[s] = (pts[order[:2]].mean(axis=0), pts[order[2:]].mean(axis=0))
        self.thorax = torso_frame(self.model, self.arms.values())
        self.ranges = JointRanges(h)
        # phi -> the centre of mass's target (NaN: free)
        self.com_target: Callable[[float], np.ndarray] | None = None
        # the legs carry the centre of mass where it must go, not a swing of the arms
        self.w_posture = leg_joint_weights(self.model, self.chains, W_POSTURE, W_UPPER)

    def norm(self, name: str, psi: float) -> float:
        """A normative angle [deg] at a side's phase psi (periodic)."""
        return float(np.interp(psi % 1.0, self.pct, self.curves[name]))

    def angles(self, psi: float) -> np.ndarray:
        """The normative side angles in clinical.ANGLES order at the side's phase."""
        return np.array([self.norm(k, psi) for k in ANGLES])

    # -- the residual ----------------------------------------------------------------------
    def wants(self, phi: float) -> tuple[dict, np.ndarray | None, dict]:
        """What the fit aims at, at the cycle's phase phi: each side's normative angles [deg],
        the centre of mass [m] (NaN where free) if it has a plan, and each arm's swing [deg]."""
        psi = {s: phi + (0.5 if s == "left" else 0.0) for s in SIDES}
        angles = {s: self.angles(psi[s]) for s in SIDES}
        arms = {s: arm_swing(psi[s] % 1.0, self.v_hat) for s in self.arms}
        return angles, None if self.com_target is None else self.com_target(phi), arms

    def residual(self, q, targets: dict, wants: tuple) -> np.ndarray:
        model, data = self.model, self.data
        pin.framesForwardKinematics(model, data, q)
        r = []
        for s, target in targets.items():
            err = target.actInv(data.oMf[self.sole[s]])
            r.append(W_FOOT * pin.log6(err).vector)
        angles, com, arms = wants
        for s, want in arms.items():
            r.append(W_ARM * np.radians(self.arms[s].angles(data) - want))
        for s in SIDES:
            a, want = self.chains[s].angles(data), angles[s]
            # the pelvis is shared: each side fits its own view of it at half weight
            r.append(W_ANGLE * math.sqrt(0.5) * np.radians(a[:3] - want[:3]))
            r.append(W_ANGLE * np.radians(a[3:] - want[3:]))
        if com is not None:
            c = pin.centerOfMass(model, data, q)
            r.append(W_COM * np.where(np.isnan(com), 0.0, c - np.nan_to_num(com)))
        if self.thorax is not None:
            R = data.oMf[self.thorax].rotation
            r.append(W_TRUNK * pin.log3(R))
        d = pin.difference(model, self.q0, q)
        r.append(self.w_posture * d[6:])
        r.append(W_RANGE * self.ranges.excess(q))

        return np.concatenate([np.ravel(x) for x in r])

    def solve(self, q, phi: float, targets: dict, iterations: int = 30) -> np.ndarray:
        """Levenberg-Marquardt (a Gauss-Newton step, damped until it lowers the cost),
        numerical Jacobian on the tangent space."""
        model = self.model
        eps = 1e-7
        wants = self.wants(phi)
        r = self.residual(q, targets, wants)
        damping = 1e-8
        for _ in range(iterations):
            J = np.empty((len(r), model.nv))
            for i in range(model.nv):
                dq = np.zeros(model.nv)
                dq[i] = eps
                J[:, i] = (self.residual(pin.integrate(model, q, dq), targets, wants) - r) / eps
            JtJ, Jtr = J.T @ J, J.T @ r
            while True:
                step = np.linalg.solve(JtJ + damping * np.eye(model.nv), -Jtr)
                q_new = pin.integrate(model, q, step)
                r_new = self.residual(q_new, targets, wants)
                if r_new @ r_new <= r @ r or damping > 1e6:
                    break
                damping *= 10.0
            q, r = q_new, r_new
            damping = max(1e-8, damping / 10.0)
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

    @functools.cached_property
    def periodic(self) -> np.ndarray:
        """c less its steady progress along x: periodic (interpolating x itself across the
        lap's end would blend in the first sample, a stride behind)."""
        return self.c - np.outer(self.phase, [self.stride, 0.0, 0.0])

    @functools.cached_property
    def _table(self) -> tuple[np.ndarray, np.ndarray]:
        """The phases and the (periodic c, dc, ddc) rows, the first repeated at phase 1."""
        rows = np.hstack([self.periodic, self.dc, self.ddc])
        return np.append(self.phase, self.phase[0] + 1.0), np.vstack([rows, rows[:1]])

    def at(self, phi: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """(c, dc, ddc) at the cycle's phase phi (any real number: laps add strides): linear
        between the samples, periodic, in ``np.interp``'s own arithmetic (the same bits as
        its nine calls, one per column, at a ninth of their cost)."""
        u = phi - math.floor(phi)
        xp, fp = self._table
        j = min(max(int(np.searchsorted(xp, u, side="right")) - 1, 0), len(xp) - 2)
        slope = (fp[j + 1] - fp[j]) / (xp[j + 1] - xp[j])
        out = slope * (u - xp[j]) + fp[j]
        out[0] += self.stride * phi
        return out[:3], out[3:6], out[6:]


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


def fit_cycle(h, speed: float | None = None, width: float | None = None,
              frames: int = FRAMES, cache: bool = True) -> GaitCycle:  # fmt: skip
    """Fit one stride of a person's gait to ``h`` (see the module docstring).

    Args:
        h: The humanoid (a free-flyer root, two legs with feet that have contact points).
        speed: Walking speed [m/s]; default the body's free speed (``norms.free_speed``).
        width: Distance between the feet's centre lines [m]; default the foot's width plus 3 %
            of the leg length (a person's walking base), at most the standing stance.
        frames: Instants per cycle.
        cache: Read the cycle from the user's cache or the package's data when a fit of the
            same body, numbers and fitting code is kept there (about 30 s saved), and keep a
            new fit in the user's cache (:mod:`humanoid.cache`); False: fit, keep nothing.
    """
    ell = leg_length(h)
    speed = free_speed(ell) if speed is None else float(speed)
    if not 0.3 <= speed <= 2.5:
        raise WalkError(f"speed must be in [0.3, 2.5] m/s, got {speed}")
    if not cache:
        return _fit(h, speed, width, frames)
    name = cycle_file(h, speed, width, frames)
    for folder in (cache_dir("cycles"), CYCLES):
        path = folder / name
        if path.is_file():
            try:
                return read_cycle(path)
            except (OSError, ValueError, KeyError, zipfile.BadZipFile):
                continue  # (a file another version wrote, or damaged: fitted again)
    cycle = _fit(h, speed, width, frames)
    try:
        write_cycle(cycle, cache_dir("cycles") / name)
    except OSError as e:  # a read-only home: the fit is only not kept
        warnings.warn(f"the fitted cycle was not cached: {e}", CacheWarning, stacklevel=2)
    return cycle


# the files whose code and data compute a fitted cycle: a cycle kept under another version of
# any of them is not found again
CYCLE_SOURCES = (
    "walking/reference.py", "walking/clinical.py", "walking/norms.py", "walking/plan.py",
    "constraints/limits.py", "data/norms/schwartz2008.json",
)  # fmt: skip
CYCLES = Path(__file__).resolve().parent.parent / "data" / "cycles"


def cycle_file(h, speed: float, width: float | None, frames: int) -> str:
    """The cache's file name of ``h``'s cycle at these numbers: the body's digest, then one of
    the numbers (exact), the fitting code and Pinocchio's version."""
    numbers = f"{float(speed)!r}|{None if width is None else float(width)!r}|{int(frames)}"
    numbers += f"|{sources_key(*CYCLE_SOURCES)}|{pin.__version__}"
    return f"{model_key(h.model)}-{hashlib.sha256(numbers.encode()).hexdigest()[:12]}.npz"


def write_cycle(cycle: GaitCycle, path) -> Path:
    """Write ``cycle`` to ``path`` (npz, whole or not at all); :func:`read_cycle` reads it."""
    c = cycle.com
    arrays = {"phase": cycle.phase, "q": cycle.q, "residual": np.float64(cycle.residual),
              "gait": np.array(json.dumps(cycle.gait)), "com_phase": c.phase, "com_c": c.c,
              "com_dc": c.dc, "com_ddc": c.ddc, "com_zmp": c.zmp,
              "com_stride": np.float64(c.stride), "com_period": np.float64(c.period)}  # fmt: skip
    for s in SIDES:
        arrays[f"feet_{s}"], arrays[f"contact_{s}"] = cycle.feet[s], cycle.contact[s]
    return write_atomic(Path(path), **arrays)


def read_cycle(path) -> GaitCycle:
    """Read a cycle :func:`write_cycle` wrote."""
    with np.load(path) as f:
        a = {k: f[k] for k in f.files}
    com = CenterOfMassPlan(a["com_phase"], a["com_c"], a["com_dc"], a["com_ddc"], a["com_zmp"],
                           float(a["com_stride"]), float(a["com_period"]))  # fmt: skip
    return GaitCycle(
        phase=a["phase"], q=a["q"], gait=json.loads(str(a["gait"])),
        feet={s: a[f"feet_{s}"] for s in SIDES}, contact={s: a[f"contact_{s}"] for s in SIDES},
        residual=float(a["residual"]), com=com,
    )  # fmt: skip


class _FootTargets:
    """The feet's poses a fit aims at: flat footsteps ``width`` apart, a stride 2 L long, each
    stance foot rolling from its heel at heel strike to its toe after heel off."""

    def __init__(self, fitter: _Fitter, gait: dict, soles0: dict, width: float) -> None:
        self.fitter, self.soles0, self.width = fitter, soles0, width
        self.L, self.off, self.flat = (
            gait["step_length"],
            gait["foot_off"],
            gait["opposite_foot_off"],
        )
        self.heel_off = 0.65 * self.off
        self.pitch_strike = self.foot_pitch(0.0)

    def step_pose(self, side: str, k: int) -> pin.SE3:
        """The flat pose of a side's k-th footstep (right k = 0 at x = 0, left k = 0 at -L)."""
        L, width = self.L, self.width
        x = 2 * L * k - (L if side == "left" else 0.0)
        y = width / 2 if side == "left" else -width / 2
        return pin.SE3(np.eye(3), np.array([x + self.soles0[side].translation[0], y, 0.0]))

    # foot pitch at heel strike and at foot off, from the normative angles: the foot against the
    # floor = ankle + hip - pelvis tilt - knee (sagittal chain, degrees; toes up positive)
    def foot_pitch(self, psi):
        a = self.fitter.angles(psi)
        return math.radians(a[7] + a[3] - a[0] - a[6])

    def stance_target(self, side, psi, k) -> tuple[pin.SE3, int]:
        """Pose of a stance foot at its phase psi (< off), on footstep k."""
        flat, heel_off = self.flat, self.heel_off
        base = self.step_pose(side, k)
        heel, toe = self.fitter.edge[side]
        if psi < flat:
            theta, pivot, kind = self.pitch_strike * (1 - smooth_step(psi / flat)), heel, 1
        elif psi < heel_off:
            return base, 2
        else:
            # the normative chain's own pitch, eased in over HEEL_RISE after heel off
            theta = min(self.foot_pitch(psi), 0.0) * smooth_step((psi - heel_off) / HEEL_RISE)
            pivot, kind = toe, 3
        # rotate about the pivot edge (toes up positive: a rotation about -y)
        R = pin.utils.rotate("y", -theta)
        p = base.translation + base.rotation @ pivot
        return pin.SE3(R, p - R @ pivot), kind

    def targets_at(self, phi, swing_paths=None):
        """Each side's target pose at the cycle's phase phi (a swing foot's on its path, if
        given) and contact kind (0 swing, 1 heel, 2 flat, 3 toe)."""
        targets, kinds = {}, {}
        for side in SIDES:
            psi_raw = phi + (0.5 if side == "left" else 0.0)
            k = int(math.floor(psi_raw))  # footstep index of the current stance
            psi = psi_raw - k
            if psi < self.off:
                targets[side], kinds[side] = self.stance_target(side, psi, k)
            else:
                kinds[side] = 0
                if swing_paths is not None:
                    targets[side] = swing_paths[side](phi)
        return targets, kinds


def _fit(h, speed: float, width: float | None, frames: int) -> GaitCycle:
    """:func:`fit_cycle`'s fit itself."""
    ell = leg_length(h)
    gait = choose_gait(speed, ell)
    fitter = _Fitter(h, gait)
    data, model = fitter.data, h.model
    pin.framesForwardKinematics(model, data, fitter.q0)
    soles0 = {s: data.oMf[fitter.sole[s]].copy() for s in SIDES}
    if width is None:
        foot_width = float(np.ptp(fitter.corners["left"][:, 1]))
        width = min(abs(soles0["left"].translation[1] - soles0["right"].translation[1]),
                    0.03 * ell + foot_width)  # fmt: skip
    L = gait["step_length"]
    phase = np.arange(frames) / frames
    steps = _FootTargets(fitter, gait, soles0, width)
    z_com0 = pin.centerOfMass(model, data, fitter.q0)[2]
    gait = gait | {"width": width, "heel_off": steps.heel_off}
    feet_plan = {
        s: (
            float(soles0[s].translation[0]) - (L if s == "left" else 0.0),
            width / 2 if s == "left" else -width / 2,
            float(fitter.edge[s][0][0]),
            float(fitter.edge[s][1][0]),
        )  # fmt: skip
        for s in SIDES
    }
    # pass 1 follows the planned sway only (its height is not known yet)
    plan = plan_com(gait, feet_plan, z_com0)
    fitter.com_target = lambda phi: np.array([np.nan, plan.at(phi)[0][1], np.nan])
    qs1, free = _free_pass(fitter, steps, phase)
    paths = {s: _swing_path(fitter, steps, free[s], s, frames) for s in SIDES}
    # pass 2: both feet constrained; the centre of mass on its plan across and along (a
    # pendulum at the first pass's mean height); its height is the legs' to choose (the plan's
    # would hold the pelvis too high for the leading leg to reach its heel strike)
    z_mean = float(np.mean([pin.centerOfMass(model, data, qk)[2] for qk in qs1]))
    plan = plan_com(gait, feet_plan, z_mean)
    fitter.com_target = lambda phi: plan.at(phi)[0] * np.array([1.0, 1.0, np.nan])
    qs, feet, contact, worst = _constrained_pass(fitter, steps, paths, qs1[0], phase)
    return GaitCycle(
        phase=phase,
        q=np.array(qs),
        gait=gait,
        feet={s: np.array(v) for s, v in feet.items()},
        contact={s: np.array(v) for s, v in contact.items()},
        residual=worst,
        com=plan,
    )


def _free_pass(fitter: _Fitter, steps: _FootTargets, phase: np.ndarray):
    """Pass 1 of a fit: the stance feet only; the swing foot goes where the normative angles
    carry it. The configurations of the cycle's second lap, and each sole's poses one stride
    back."""
    model, data, L = fitter.model, fitter.data, steps.L
    q = fitter.q0.copy()
    q[0] += 1.5 * L  # between the footsteps of the second lap
    qs1: list[np.ndarray] = []
    free: dict[str, list[pin.SE3]] = {s: [] for s in SIDES}
    back = pin.SE3(np.eye(3), np.array([-2 * L, 0.0, 0.0]))  # one stride back
    for phi in phase + 1.0:  # the second lap (footsteps k = 1, 2), from the standing posture
        targets, _ = steps.targets_at(phi)
        q = fitter.solve(q, phi, targets, iterations=100 if phi == 1.0 else 30)
        qs1.append(q.copy())
        pin.framesForwardKinematics(model, data, q)
        for s in SIDES:
            free[s].append(back * data.oMf[fitter.sole[s]])
    return qs1, free


def _swing_path(fitter: _Fitter, steps: _FootTargets, free: list, s: str, frames: int):
    """The swing of side ``s``: its free path (``free``, a sole pose per frame) bent to leave
    from the foot-off pose and land on the heel-strike pose, as a function of the phase."""
    L, off = steps.L, steps.off
    shift = 0.5 if s == "left" else 0.0
    # the free path's first swing frame (rounding could pick the last stance frame, where
    # pass 1 held the foot on its footstep: the bend then missed the free path's jump at
    # foot off, 9 cm across on the g1, and the swing started at 3 m/s)
    i_off = math.ceil(((off - shift) % 1.0) * frames - 1e-9) % frames
    i_on = int(round(((1.0 - shift) % 1.0) * frames)) % frames
    start, _ = steps.stance_target(s, off - 1e-9, 0)
    end, _ = steps.stance_target(s, 0.0, 1)
    # the free path where it would land: its last swing pose carried on one frame at its
    # own velocity (free[i_on] is already the stance's heel-strike pose: blending to it
    # kept the foot 4 cm up until the last frame, then dropped it, and the body with it,
    # onto the floor: a controller tracking that lifted the female body off its feet)
    i_last = (i_on - 1) % frames
    last, before = free[i_last], free[(i_last - 1) % frames]
    a0, a1 = free[i_off], last * before.actInv(last)
    if i_last < i_off:  # the free path's landing instant is in the next lap
        a1 = pin.SE3(np.eye(3), np.array([2 * L, 0.0, 0.0])) * a1
    dp0, dp1 = start.translation - a0.translation, end.translation - a1.translation
    dr0 = pin.log3(a0.rotation.T @ start.rotation)
    dr1 = pin.log3(a1.rotation.T @ end.rotation)

    def path(phi):
        psi_raw = phi + shift
        k = int(math.floor(psi_raw))  # the footstep the foot left
        u = (psi_raw - k - off) / (1.0 - off)  # 0 at foot off, 1 at heel strike
        i = int(round((phi % 1.0) * frames)) % frames
        M = free[i]
        w = float(smooth_step(u))
        p = M.translation + (1 - w) * dp0 + w * dp1
        p[0] += 2 * L * k
        R = M.rotation @ pin.exp3((1 - w) * dr0 + w * dr1)
        # above the floor: the lowest corner at least CLEARANCE up in mid-swing
        lowest = min((R @ c + p)[2] for c in fitter.corners[s])
        p[2] += max(0.0, CLEARANCE * math.sin(math.pi * min(max(u, 0.0), 1.0)) - lowest)
        return pin.SE3(R, p)

    return path


def _constrained_pass(fitter: _Fitter, steps: _FootTargets, paths: dict, q1: np.ndarray,
                      phase: np.ndarray):  # fmt: skip
    """Pass 2 of a fit, from pass 1's first configuration ``q1``: both feet's poses
    constraints. Its configurations, soles' poses (x, y, z, roll, pitch, yaw), contact kinds
    and the largest stance-foot residual."""
    model, data = fitter.model, fitter.data
    qs: list[np.ndarray] = []
    feet: dict[str, list[np.ndarray]] = {s: [] for s in SIDES}
    contact: dict[str, list[int]] = {s: [] for s in SIDES}
    worst = 0.0
    q = q1.copy()
    q[0] -= 2 * steps.L  # pass 1 ran one stride on
    for phi in phase:
        targets, kinds = steps.targets_at(phi, paths)
        q = fitter.solve(q, phi, targets)
        pin.framesForwardKinematics(model, data, q)
        for s in SIDES:
            M = data.oMf[fitter.sole[s]]
            if kinds[s]:  # a stance foot's pose is a constraint
                worst = max(worst, float(np.abs(pin.log6(targets[s].actInv(M)).vector).max()))
            feet[s].append(np.concatenate([M.translation, pin.rpy.matrixToRpy(M.rotation)]))
            contact[s].append(kinds[s])
        qs.append(q.copy())
    return qs, feet, contact, worst
