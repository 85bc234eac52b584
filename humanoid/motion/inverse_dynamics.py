"""Inverse dynamics of a motion: the joint moments that produce it under its external loads.

``tau = M(q) a + b(q, v) - sum_k J_k(q)^T f_k`` (Pinocchio's RNEA with external forces), at
every sample of a motion given as configurations ``q`` over time:

1. **Resampled** to a uniform rate (the motion's own mean rate unless ``rate`` is given):
   translations and joint angles linearly, rotations (quaternions) by spherical interpolation.
2. **Filtered** (``cutoff``, default 6 Hz; None: not filtered): a zero-lag Butterworth low-pass
   (2nd order, run forward and back: 4th order, no phase lag; scipy's ``filtfilt``), on every
   coordinate, quaternions component-wise after making them continuous (``q`` and ``-q`` are
   the same rotation) and normalised after; the loads through the same filter, as wrenches
   about the world origin (filtering the kinematics and not the forces makes spikes in the
   moments at every heel strike).
3. **Differentiated** on the configuration's Lie group: ``pin.difference`` of consecutive
   samples. ``velocity="central"`` takes the mean of the two neighbouring differences;
   ``"backward"`` the difference that reached the sample, which is how a semi-implicit Euler
   simulation defines its velocity (a motion recorded from one at every step then gives back
   its torques to rounding); the acceleration is the second difference either way, and the
   first and last samples take their neighbour's.

The root (free-flyer) rows of ``tau`` are the **residuals**: the force and moment the motion
needs at the pelvis that nothing in the model provides (zero for a motion consistent with its
loads), reported in world axes, the moment about the pelvis origin, as OpenSim reports its
pelvis residuals.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np
import pinocchio as pin

from ..errors import ConfigurationError, InverseDynamicsError
from ..model import SIDES
from .coordinates import motion_floor
from .loads import Load
from .storage import MAX_RATE, MotionFileError, check_rate

LWA = pin.ReferenceFrame.LOCAL_WORLD_ALIGNED

__all__ = [
    "InverseDynamics",
    "carry_loads",
    "contact_schedule",
    "derivatives",
    "estimate_loads",
    "inverse_dynamics",
    "joint_labels",
    "load_frame",
    "lowpass",
    "quaternion_slots",
    "recorded_feet",
    "residual_cutoff",
    "stances",
]


@dataclass
class InverseDynamics:
    """The result of :func:`inverse_dynamics`.

    Attributes:
        time: (n,) [s]. q, v, a: the (resampled, filtered) motion and its derivatives.
        tau: Generalised forces (n, nv): the joints' moments [N m] (forces for prismatic
            joints); its first six (the root's) are the residuals in the root's frame.
        residual_force, residual_moment: The residuals in world axes, (n, 3) [N, N m] (the
            moment about the root's origin).
        labels: One name per generalised velocity (:func:`joint_labels`).
        loads: The external wrenches applied, per load body, about the world origin (n, 6).
        carried: The shifts of the feet's loads (:func:`carry_loads`), if carried.
    """

    time: np.ndarray
    q: np.ndarray
    v: np.ndarray
    a: np.ndarray
    tau: np.ndarray
    residual_force: np.ndarray
    residual_moment: np.ndarray
    labels: list[str]
    loads: dict = field(default_factory=dict)
    carried: list = field(default_factory=list)

    def moment(self, label: str) -> np.ndarray:
        """One generalised force's time series by its label."""
        try:
            return self.tau[:, self.labels.index(label)]
        except ValueError:
            raise InverseDynamicsError(
                f"no coordinate {label!r}; the labels: {self.labels}"
            ) from None


def joint_labels(model: pin.Model, root=("fx", "fy", "fz", "mx", "my", "mz")) -> list[str]:
    """A name per generalised velocity: a one-DoF joint's own name; ``<joint>_x/_y/_z`` for a
    spherical joint's axes (its local frame); the root's ``root_fx, fy, fz, mx, my, mz`` (its
    generalised forces; ``root``: other suffixes, e.g. its velocity's)."""
    out = []
    for j in range(1, model.njoints):
        joint, name = model.joints[j], model.names[j]
        short = joint.shortname()
        if "FreeFlyer" in short:
            out += [f"{name}_{c}" for c in root]
        elif joint.nv == 1:
            out.append(name)
        else:
            out += (
                [f"{name}_{c}" for c in "xyz"[: joint.nv]]
                if joint.nv <= 3
                else [f"{name}_{i}" for i in range(joint.nv)]
            )
    return out


def quaternion_slots(model: pin.Model) -> list[int]:
    """The first index in q of every unit quaternion (free flyers' and spherical joints')."""
    out = []
    for j in range(1, model.njoints):
        short = model.joints[j].shortname()
        if "FreeFlyer" in short:
            out.append(model.idx_qs[j] + 3)
        elif "Spherical" in short and "ZYX" not in short:
            out.append(model.idx_qs[j])
    return out


def _continuous(q: np.ndarray, slots: list[int]) -> np.ndarray:
    """Quaternions flipped sample by sample to stay on one hemisphere (q, -q: one rotation):
    each sample's sign is the product of the signs of the dot products before it."""
    q = q.copy()
    for s in slots:
        block = q[:, s : s + 4]
        dots = np.einsum("ij,ij->i", block[1:], block[:-1])
        signs = np.cumprod(np.where(dots < 0.0, -1.0, 1.0))
        block[1:] *= signs[:, None]
    return q


def _normalise(q: np.ndarray, slots: list[int]) -> np.ndarray:
    for s in slots:
        q[:, s : s + 4] /= np.linalg.norm(q[:, s : s + 4], axis=1, keepdims=True)
    return q


def _resample(model, time, q, new_time) -> np.ndarray:
    """q at new_time: pin.interpolate between the bracketing samples (exact at the samples)."""
    i = np.clip(np.searchsorted(time, new_time, side="right") - 1, 0, len(time) - 2)
    u = np.clip((new_time - time[i]) / (time[i + 1] - time[i]), 0.0, 1.0)
    pairs = zip(i, u, strict=True)
    return np.array([pin.interpolate(model, q[k], q[k + 1], float(w)) for k, w in pairs])


def lowpass(x: np.ndarray, rate: float, cutoff: float) -> np.ndarray:
    """Zero-lag 4th-order Butterworth low-pass of each column (2nd order, forward and back)."""
    from scipy.signal import butter, filtfilt

    if not 0.0 < cutoff < rate / 2.0:
        raise InverseDynamicsError(
            f"the filter's cutoff must be between 0 and half the rate ({rate / 2:g} Hz), got "
            f"{cutoff:g} Hz"
        )
    b, a = butter(2, cutoff / (rate / 2.0))
    if len(x) <= 3 * max(len(a), len(b)):
        raise InverseDynamicsError(f"{len(x)} samples are too few to filter (at least 10)")
    return filtfilt(b, a, x, axis=0)


def residual_cutoff(model, time, q) -> float:
    """The low-pass cutoff [Hz] of a motion by Winter's residual analysis (Winter, Biomechanics
    and Motor Control of Human Movement, 4th ed. 2009, section 3.4.4.3): for each coordinate
    that moves, the RMS residual between it and its filtered self at cutoffs from 1 Hz to
    0.45 of the rate; the residual's straight line over the upper half of those cutoffs (where
    only noise is left) meets zero cutoff at the noise's RMS; the coordinate's cutoff is the
    lowest at which the residual is down to it. The motion's is the median over its
    coordinates (the configuration's tangent from the first sample: angles and the root's
    position alike). A noisier or sparser motion gets a lower cutoff: BODY_25's points of a
    3-step walk at 30 Hz with 1 cm of noise, fitted, gave 2.0-2.4 Hz over 5 seeds
    (``tests/test_video_rates.py``); a clean walk gets a high one (its impacts are signal)."""
    time, q = _checked(model, time, q)
    rate = (len(time) - 1) / (time[-1] - time[0])
    x = np.array([pin.difference(model, q[0], qi) for qi in q])
    x = x[:, np.std(x, axis=0) > 1e-9]
    if x.shape[1] == 0:
        raise InverseDynamicsError("the motion does not move: no cutoff to find")
    cutoffs = np.arange(1.0, 0.45 * rate, 0.25)
    if len(cutoffs) < 8:
        raise InverseDynamicsError(f"a motion at {rate:.1f} Hz is too slow for a residual analysis "
                                   f"(at least 7 Hz)")  # fmt: skip
    residual = np.array([np.sqrt(np.mean((x - lowpass(x, rate, f)) ** 2, axis=0))
                         for f in cutoffs])  # fmt: skip
    noise = cutoffs >= cutoffs[len(cutoffs) // 2]
    found = []
    for k in range(x.shape[1]):
        intercept = np.polyfit(cutoffs[noise], residual[noise, k], 1)[1]
        below = np.flatnonzero(residual[:, k] <= intercept)
        found.append(cutoffs[below[0]] if len(below) else cutoffs[-1])
    return float(np.median(found))


# [s] the longest gap between two samples of a motion to differentiate: motion capture loses
# a few frames at most; across a longer gap the resampled motion (and its accelerations) is
# invented, and a gap of 1e9 s asked for a 74.5 GiB grid
MAX_GAP = 1.0
# the most samples of a resampled motion: an hour at 250 Hz; (n, nv) arrays of more take
# gigabytes
MAX_SAMPLES = 1_000_000


def _checked(model, time, q) -> tuple[np.ndarray, np.ndarray]:
    time = np.asarray(time, dtype=float).reshape(-1)
    q = np.asarray(q, dtype=float)
    if q.ndim != 2 or q.shape[1] != model.nq or len(q) != len(time):
        raise ConfigurationError(
            f"q must be (n, nq) = ({len(time)}, {model.nq}) for {len(time)} times, got {q.shape}"
        )
    if not np.all(np.isfinite(q)) or not np.all(np.isfinite(time)):
        raise ConfigurationError("the motion has non-finite entries")
    if len(time) < 3:
        raise InverseDynamicsError(f"a motion needs at least 3 samples, got {len(time)}")
    if not np.all(np.diff(time) > 0):
        raise InverseDynamicsError("the motion's time must increase")
    check_rate(time, "the motion")
    gap = int(np.argmax(np.diff(time)))
    if time[gap + 1] - time[gap] > MAX_GAP:
        raise MotionFileError(
            f"the motion has a gap of {time[gap + 1] - time[gap]:.3g} s (from {time[gap]:.6g} "
            f"to {time[gap + 1]:.6g} s), more than {MAX_GAP:g} s: differentiating across it "
            "would invent the motion; split the record there"
        )
    slots = quaternion_slots(model)
    return time, _normalise(_continuous(q, slots), slots)


def derivatives(model, time, q, *, cutoff: float | str | None = 6.0,
                rate: float | None = None,
                velocity: str = "central",
                ) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:  # fmt: skip
    """A motion resampled, filtered and differentiated (steps 1-3 of the module docstring):
    (time, q, v, a) on a uniform grid. ``cutoff``: [Hz], None (unfiltered) or ``"auto"``
    (:func:`residual_cutoff` of the resampled motion)."""
    if velocity not in ("central", "backward"):
        raise InverseDynamicsError(f"velocity must be 'central' or 'backward', got {velocity!r}")
    time, q = _checked(model, time, q)
    slots = quaternion_slots(model)
    rate = float(rate) if rate is not None else (len(time) - 1) / (time[-1] - time[0])
    if not 0.0 < rate <= MAX_RATE:
        raise InverseDynamicsError(f"the rate must be in (0, {MAX_RATE:g}] Hz, got {rate:g}")
    if (time[-1] - time[0]) * rate + 1 > MAX_SAMPLES:
        raise InverseDynamicsError(
            f"{time[-1] - time[0]:.6g} s at {rate:g} Hz is more than {MAX_SAMPLES:g} samples: "
            "give a lower rate or a shorter record"
        )
    n = int(math.floor((time[-1] - time[0]) * rate + 1e-9)) + 1
    uniform = time[0] + np.arange(n) / rate
    if n != len(time) or not np.allclose(uniform, time, rtol=0.0, atol=1e-9 / rate):
        q = _continuous(_resample(model, time, q, uniform), slots)
    if cutoff == "auto":
        cutoff = residual_cutoff(model, uniform, q)
    if cutoff is not None:
        q = _normalise(lowpass(q, rate, float(cutoff)), slots)
    dt = 1.0 / rate
    d = np.array([pin.difference(model, q[i], q[i + 1]) for i in range(n - 1)]) / dt
    v = np.empty((n, model.nv))
    a = np.empty((n, model.nv))
    a[1:-1] = (d[1:] - d[:-1]) / dt
    a[0], a[-1] = a[1], a[-2]
    if velocity == "backward":
        v[1:], v[0] = d, d[0]
    else:
        v[1:-1] = 0.5 * (d[1:] + d[:-1])
        v[0], v[-1] = d[0], d[-1]
    return uniform, q, v, a


def inverse_dynamics(h, time, q, loads: list[Load] | tuple = (), *, cutoff: float | None = 6.0,
                     rate: float | None = None, velocity: str = "central",
                     recorded_feet: dict | None = None) -> InverseDynamics:  # fmt: skip
    """Inverse dynamics of the motion ``q`` (n, nq) at ``time`` (n,) under ``loads`` (see the
    module docstring).

    Args:
        h: The :class:`~humanoid.model.Humanoid`. loads: :class:`~humanoid.motion.loads.Load` s
            on its feet (``"left"``, ``"right"``) or on frames by name.
        cutoff: The low-pass cutoff [Hz] (None: unfiltered). rate: Resample to this rate [Hz]
            (default: the motion's mean rate). velocity: ``"central"`` or ``"backward"``.
        recorded_feet: {side: (n, 3)} where the recorded feet's sole middles were: their
            loads are carried with the body's feet (:func:`carry_loads`); default: every
            load acts where it was measured, as OpenSim applies it.

    Raises:
        ConfigurationError: q of the wrong shape or not finite. InverseDynamicsError: fewer than 3
            samples, time not increasing, a load on a body the model does not have.
    """
    model = h.model
    time, q = _checked(model, time, q)
    carried: list[tuple] = []
    if recorded_feet:  # at the motion's own samples, where the recorded feet are given
        loads, carried = carry_loads(h, time, q, loads, recorded_feet)
    time, q, v, a = derivatives(model, time, q, cutoff=cutoff, rate=rate, velocity=velocity)
    rate = 1.0 / (time[1] - time[0])
    n = len(time)
    wrenches: dict[str, tuple[int, np.ndarray]] = {}
    for load in loads:
        j = _load_joint(h, load.body)
        wrenches[load.body] = (j, wrenches.get(load.body, (j, 0.0))[1] + load.resampled(time))
    if cutoff is not None:
        wrenches = {k: (j, lowpass(w, rate, cutoff)) for k, (j, w) in wrenches.items()}
    data = model.createData()
    tau = np.empty((n, model.nv))
    res_f, res_m = np.zeros((n, 3)), np.zeros((n, 3))
    free = "FreeFlyer" in model.joints[1].shortname()
    fext = pin.StdVec_Force()
    for _ in range(model.njoints):
        fext.append(pin.Force.Zero())
    per_joint: dict[
        int, np.ndarray
    ] = {}  # the loads on each joint, summed: world wrenches about the origin
    for j, w in wrenches.values():
        per_joint[j] = per_joint.get(j, 0.0) + w
    for i in range(n):
        pin.forwardKinematics(model, data, q[i])
        for j, w in per_joint.items():
            fext[j] = data.oMi[j].actInv(pin.Force(w[i, :3], w[i, 3:]))
        tau[i] = pin.rnea(model, data, q[i], v[i], a[i], fext)
        if free:
            R = data.oMi[1].rotation
            res_f[i], res_m[i] = R @ tau[i, :3], R @ tau[i, 3:6]
    return InverseDynamics(time, q, v, a, tau, res_f, res_m, joint_labels(model),
                           {k: w for k, (_, w) in wrenches.items()}, carried)  # fmt: skip


def contact_schedule(h, time, q, v, loads=(), height: float = 0.02, speed: float = 0.3,
                     force: float = 20.0, floor=None, shortest: float = 0.1,
                     fill: bool = True) -> dict:  # fmt: skip
    """When each foot is on the ground: {side: (time, bool array)}. From a foot's measured load
    (vertical force over ``force`` [N]) if it has one, else from the motion: one of its sole
    points within ``height`` [m] of the motion's floor (the median over its samples of the
    lowest sole point) and moving with
    the floor, slower than ``speed`` [m/s] relative to it (a trailing foot rolls on its toes
    while its frame moves fast). The floor's own velocity is the median horizontal velocity of
    the sole points that are low: zero over ground, the belt's on a treadmill (where the body
    stays put and the standing foot moves back at the walking speed), or the ``floor``'s own
    belt if given. ``floor``: a
    :class:`~humanoid.motion.floor.Floor` (:func:`~humanoid.motion.floor.fit_floor`): heights
    are measured above it, along its normal, and within ``height`` of it is low (default
    None: the horizontal plane of the motion's floor, as above). From the motion, gaps and
    then contacts shorter than ``shortest`` [s] are removed (a noisy motion's foot flickers;
    a stance or a swing of a walk lasts 0.3 s or more). ``fill``: a stance the motion has for
    a foot whose measured load reads nothing through all of it (a step beside the plates) is
    a contact too (False: the measured loads alone)."""
    model = h.model
    data = model.createData()
    out = {}
    measured = {x.body: x for x in loads if x.body in SIDES}
    # (the points' own frames: a foot with free toes carries its toe points on them)
    pts = {s: [h.frame_id(n) for n in h.require_contact_points(s)] for s in SIDES}
    # per sole point: its height and speed; a foot is down where one of its points is low and
    # still (a trailing foot rolls on its toes while its frame moves fast)
    low = {s: np.zeros((len(time), len(pts[s]))) for s in SIDES}
    vel = {s: np.zeros((len(time), len(pts[s]), 3)) for s in SIDES}
    for i in range(len(time)):
        pin.forwardKinematics(model, data, q[i], v[i])
        for s in SIDES:
            world = np.array([pin.updateFramePlacement(model, data, f).translation
                              for f in pts[s]])  # fmt: skip
            low[s][i] = world[:, 2] if floor is None else floor.above(world)
            vel[s][i] = [pin.getFrameVelocity(model, data, f, LWA).linear for f in pts[s]]
    # the motion's floor: the median over samples of the lowest sole point (in a walk a foot
    # always stands; the lowest of all is a rigid foot's tip through the floor at push-off,
    # 4-5 cm under walking5's stances, under which no stance was found)
    lowest = np.minimum(*(x.min(axis=1) for x in low.values()))
    base = float(np.median(lowest)) if floor is None else 0.0
    if floor is not None:  # (its belt fitted with it: floor.belt_velocity)
        belt = np.asarray(floor.belt, dtype=float)
    else:
        near = np.concatenate([vel[s][low[s] < base + height] for s in SIDES])
        belt = np.array([*np.median(near[:, :2], axis=0), 0.0]) if len(near) else np.zeros(3)
    fast = {s: np.linalg.norm(vel[s] - belt, axis=2) for s in SIDES}
    for s in SIDES:
        down = ((low[s] < base + height) & (fast[s] < speed)).any(axis=1)
        down = _debounced(down, np.asarray(time), shortest)
        if s in measured:
            fz = np.interp(time, measured[s].time, measured[s].force[:, 2], left=0.0, right=0.0)
            on = fz > force
            if fill:  # the motion's stances that no plate saw (plates that miss steps)
                from ..walking.gait import contact_runs

                for a, b in contact_runs(down, np.asarray(time), 0.0):
                    if not on[a:b].any():
                        on[a:b] = True
            out[s] = (np.asarray(time), on)
        else:
            out[s] = (np.asarray(time), down)
    return out


def _debounced(x: np.ndarray, time: np.ndarray, shortest: float) -> np.ndarray:
    """``x`` without its gaps and then its runs shorter than ``shortest`` [s] (a noisy motion's
    foot flickering off the floor mid-stance, or touching it for a frame in swing), but for a
    run the record's start or end cuts (a foot landing in its last frames: its stance is as
    long as the record leaves it, and without it the body would have no foot down there)."""
    from ..walking.gait import contact_runs

    out = np.zeros(len(x), dtype=bool)
    for a, b in contact_runs(x, time, shortest):
        out[a:b] = True
    for a, b in contact_runs(x, time, 0.0):  # (every run as it is)
        if a == 0 or b == len(x):
            out[a:b] = True
    return out


def estimate_loads(h, time, q, v, a, contacts: dict | None = None, mu: float = 0.8,
                   regularization: float = 1e-6, lift: float = 0.005,
                   floor=None) -> list[Load]:  # fmt: skip
    """The ground forces on the feet that make the motion's root residual smallest, without
    force plates: in each sample, each foot in contact (``contacts``, default
    :func:`contact_schedule` from the motion) gets a force at each of its sole points, inside
    a friction pyramid (so its centre of pressure stays under the sole), found by a QP (ProxQP)
    that minimises the squared root residual plus ``regularization`` times the squared forces
    (per body weight, each point's times ``1 + (height / lift)^2``, its height above the
    motion's floor: it shares the load of a double support, which the residual alone does not
    fix, towards the points on the floor). Returns a :class:`Load` per foot, on the motion's
    samples, its centre of pressure on the floor.

    ``floor``: a :class:`~humanoid.motion.floor.Floor` (:func:`~humanoid.motion.floor.fit_floor`)
    the feet stand on: contact is judged on it (:func:`contact_schedule`), heights measured
    above it along its normal, the friction pyramids aligned with it and the centres of
    pressure placed on it; default None: the horizontal plane of the motion's lowest sole
    point for contact and heights, world-vertical pyramids, centres of pressure on z = 0."""
    import proxsuite

    from ..control.qp import pyramid_rows

    model = h.model
    data = model.createData()
    contacts = contacts or contact_schedule(h, time, q, v, floor=floor)
    sides = ("left", "right")
    pts = {s: h.sole_points(s) for s in sides}
    weight = h.mass * float(np.linalg.norm(model.gravity.linear))
    wrench = {s: np.zeros((len(time), 6)) for s in sides}
    base = motion_floor(h, q) if floor is None else 0.0
    turn = np.eye(3) if floor is None else floor.rotation  # floor axes to world axes
    for i in range(len(time)):
        down = [s for s in sides if contacts[s][1][min(i, len(contacts[s][1]) - 1)]]
        if not down:
            continue
        b6 = pin.rnea(model, data, q[i], v[i], a[i])[:6]  # what the root needs
        pin.forwardKinematics(model, data, q[i])  # (RNEA leaves the world placements)
        R, o = data.oMi[1].rotation, data.oMi[1].translation
        cols, where, cost = [], [], []
        for s in down:
            M = pin.updateFramePlacement(model, data, h.sole_id(s))
            for p in pts[s] @ M.rotation.T + M.translation:
                # a world force f at p, as the root's generalised force: R'f, R'((p - o) x f)
                cols.append(np.vstack([R.T, R.T @ pin.skew(p - o)]) @ turn)
                where.append((s, p))
                # a point higher above the motion's floor is dearer (a heel rising, a foot
                # about to lift or just landing takes less of the load); one under it is on it
                up = max(p[2] - base if floor is None else float(floor.above(p)), 0.0)
                cost += [1.0 + (up / lift) ** 2] * 3
        A = np.hstack(cols) * weight  # forces in body weights
        n = A.shape[1]
        H = A.T @ A + regularization * weight**2 * np.diag(cost)
        g = -A.T @ b6
        C = pyramid_rows(mu, n // 3, n, 0)
        res = proxsuite.proxqp.dense.solve(H, g, None, None, C, np.full(len(C), -1e20),
                                           np.zeros(len(C)), eps_abs=1e-10)  # fmt: skip
        f = np.asarray(res.x).reshape(-1, 3) @ turn.T * weight  # in world axes
        for (s, p), fk in zip(where, f, strict=True):
            wrench[s][i] += np.concatenate([fk, np.cross(p, fk)])
    if floor is None:
        return [Load.from_wrench(s, time, wrench[s], name="estimated") for s in sides]
    out = []
    for s in sides:
        point, torque = floor.centre_of_pressure(wrench[s])
        out.append(Load(s, np.asarray(time), wrench[s][:, :3], point, torque, "estimated"))
    return out


def recorded_feet(h, time, q, markers, marker_set: dict) -> dict:
    """Where the recorded feet's sole middles were, from the markers on the body's feet: the
    body's sole middle moved by the mean misfit of that foot's markers (measured minus the
    body's) in each sample, {side: (n, 3)} at ``time``, for the sides whose foot carries
    markers that were seen (:func:`carry_loads`)."""
    model = h.model
    data = model.createData()
    out = {}
    for s in SIDES:
        foot = model.frames[h.sole_id(s)].parentJoint

        def on_foot(n, foot=foot):
            return model.frames[model.getFrameId(marker_set[n].frame)].parentJoint == foot

        names = [n for n in markers.names if n in marker_set and on_foot(n)]
        if not names:
            continue
        cols = [markers.names.index(n) for n in names]
        measured = np.stack(
            [np.column_stack([np.interp(time, markers.time, markers.positions[:, c, k])
                              for k in range(3)]) for c in cols], axis=1)  # fmt: skip
        middle = h.sole_points(s).mean(axis=0)
        place = np.zeros((len(time), 3))
        for i in range(len(time)):
            pin.framesForwardKinematics(model, data, q[i])
            body = np.array([data.oMf[model.getFrameId(marker_set[n].frame)].act(
                np.asarray(marker_set[n].offset)) for n in names])  # fmt: skip
            gap = measured[i] - body
            seen = np.all(np.isfinite(gap), axis=1)
            shift = gap[seen].mean(axis=0) if seen.any() else np.zeros(3)
            place[i] = data.oMf[h.sole_id(s)].act(middle) + shift
        out[s] = place
    return out


def stances(load: Load, threshold: float = 20.0) -> list[tuple[int, int]]:
    """The (first, last) sample of each interval in which the load's vertical force exceeds
    ``threshold`` [N] (or 2 % of its peak, if larger)."""
    fz = load.force[:, 2]
    on = fz > max(threshold, 0.02 * float(np.abs(fz).max(initial=0.0)))
    edges = np.flatnonzero(np.diff(on.astype(int)))
    starts = [0] if on[0] else []
    starts += [int(e) + 1 for e in edges if not on[e]]
    ends = [int(e) for e in edges if on[e]] + ([len(fz) - 1] if on[-1] else [])
    return list(zip(starts, ends, strict=True))


def carry_loads(h, time, q, loads, recorded: dict) -> tuple[list[Load], list[tuple]]:
    """Each foot's load carried with the body's foot, stance by stance.

    The body is not the one the motion was recorded on, so its feet are not exactly where the
    recorded feet were (other leg lengths, another step width), and a load applied where it
    was measured would act at the wrong place on the foot. ``recorded`` gives, per side, where
    the recorded foot's sole middle was at the motion's ``time`` (n, 3) (from its markers, by
    inverse kinematics); in each stance (:func:`stances`) the load's points move horizontally
    by the mean (weighted by the vertical force) of the body's sole middle minus the recorded
    one, so each load keeps its place relative to the foot that bears it. Loads on other bodies,
    and feet without a recorded position, stay where they were measured.

    Returns:
        (the loads, and per stance (body, start time, end time, shift x, shift y) [s, m]).
    """
    model = h.model
    data = model.createData()
    out, shifts = [], []
    for load in loads:
        if load.body not in recorded:
            out.append(load)
            continue
        sole = h.sole_id(load.body)
        middle = h.sole_points(load.body).mean(axis=0)
        ours = np.zeros((len(time), 3))
        for k in range(len(time)):
            pin.framesForwardKinematics(model, data, q[k])
            ours[k] = data.oMf[sole].act(middle)
        gap = ours - np.asarray(recorded[load.body], dtype=float).reshape(len(time), 3)
        gap = np.column_stack([np.interp(load.time, time, gap[:, i]) for i in range(3)])
        point = load.point.copy()
        fz = load.force[:, 2]
        for a, b in stances(load):
            w = fz[a : b + 1]
            d = (gap[a : b + 1] * w[:, None]).sum(axis=0) / w.sum()
            point[a : b + 1, :2] += d[:2]
            shifts.append((load.body, float(load.time[a]), float(load.time[b]), float(d[0]),
                           float(d[1])))  # fmt: skip
        out.append(Load(load.body, load.time, load.force, point, load.torque, load.name))
    return out, shifts


def _load_joint(h, body: str) -> int:
    """The joint a load's body moves with: a foot's (its sole frame's parent) or a frame's."""
    return h.model.frames[load_frame(h, body)].parentJoint


def load_frame(h, body: str) -> int:
    """The frame a load's body names: a foot's sole frame ('left', 'right') or the frame of
    that name."""
    model = h.model
    if body in ("left", "right"):
        return h.sole_id(body)
    if model.existFrame(body):
        return model.getFrameId(body)
    raise InverseDynamicsError(
        f"a load is applied to {body!r}, which {h.source} does not have (a foot: 'left', "
        "'right', or a frame name)"
    )
