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

from ..errors import ConfigurationError, HumanoidError
from .loads import Load

__all__ = [
    "InverseDynamics",
    "carry_loads",
    "derivatives",
    "inverse_dynamics",
    "joint_labels",
    "lowpass",
    "quaternion_slots",
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
            raise HumanoidError(f"no coordinate {label!r}; the labels: {self.labels}") from None


def joint_labels(model: pin.Model) -> list[str]:
    """A name per generalised velocity: a one-DoF joint's own name; ``<joint>_x/_y/_z`` for a
    spherical joint's axes (its local frame); the root's ``root_fx, fy, fz, mx, my, mz``."""
    out = []
    for j in range(1, model.njoints):
        joint, name = model.joints[j], model.names[j]
        short = joint.shortname()
        if "FreeFlyer" in short:
            out += [f"{name}_{c}" for c in ("fx", "fy", "fz", "mx", "my", "mz")]
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
    """Quaternions flipped sample by sample to stay on one hemisphere (q, -q: one rotation)."""
    q = q.copy()
    for s in slots:
        block = q[:, s : s + 4]
        for i in range(1, len(block)):
            if block[i] @ block[i - 1] < 0.0:
                block[i] = -block[i]
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
        raise HumanoidError(
            f"the filter's cutoff must be between 0 and half the rate ({rate / 2:g} Hz), got "
            f"{cutoff:g} Hz"
        )
    b, a = butter(2, cutoff / (rate / 2.0))
    if len(x) <= 3 * max(len(a), len(b)):
        raise HumanoidError(f"{len(x)} samples are too few to filter (at least 10)")
    return filtfilt(b, a, x, axis=0)


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
        raise HumanoidError(f"a motion needs at least 3 samples, got {len(time)}")
    if not np.all(np.diff(time) > 0):
        raise HumanoidError("the motion's time must increase")
    slots = quaternion_slots(model)
    return time, _normalise(_continuous(q, slots), slots)


def derivatives(model, time, q, *, cutoff: float | None = 6.0, rate: float | None = None,
                velocity: str = "central") -> tuple[np.ndarray, ...]:  # fmt: skip
    """A motion resampled, filtered and differentiated (steps 1-3 of the module docstring):
    (time, q, v, a) on a uniform grid."""
    if velocity not in ("central", "backward"):
        raise HumanoidError(f"velocity must be 'central' or 'backward', got {velocity!r}")
    time, q = _checked(model, time, q)
    slots = quaternion_slots(model)
    rate = float(rate) if rate is not None else (len(time) - 1) / (time[-1] - time[0])
    n = int(math.floor((time[-1] - time[0]) * rate + 1e-9)) + 1
    uniform = time[0] + np.arange(n) / rate
    if n != len(time) or not np.allclose(uniform, time, rtol=0.0, atol=1e-9 / rate):
        q = _continuous(_resample(model, time, q, uniform), slots)
    if cutoff is not None:
        q = _normalise(lowpass(q, rate, cutoff), slots)
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
        ConfigurationError: q of the wrong shape or not finite. HumanoidError: fewer than 3
            samples, time not increasing, a load on a body the model does not have.
    """
    model = h.model
    time, q = _checked(model, time, q)
    carried = []
    if recorded_feet:  # at the motion's own samples, where the recorded feet are given
        loads, carried = carry_loads(h, time, q, loads, recorded_feet)
    time, q, v, a = derivatives(model, time, q, cutoff=cutoff, rate=rate, velocity=velocity)
    rate = 1.0 / (time[1] - time[0])
    n = len(time)
    wrenches = {}
    for load in loads:
        j = _load_joint(h, load.body)
        wrenches[load.body] = (j, wrenches.get(load.body, (j, 0.0))[1] + load.resampled(time))
    if cutoff is not None:
        wrenches = {k: (j, lowpass(w, rate, cutoff)) for k, (j, w) in wrenches.items()}
    data = model.createData()
    tau = np.empty((n, model.nv))
    res_f, res_m = np.zeros((n, 3)), np.zeros((n, 3))
    free = "FreeFlyer" in model.joints[1].shortname()
    for i in range(n):
        pin.forwardKinematics(model, data, q[i])
        fext = pin.StdVec_Force()
        for _ in range(model.njoints):
            fext.append(pin.Force.Zero())
        for j, w in wrenches.values():
            fext[j] = fext[j] + data.oMi[j].actInv(pin.Force(w[i, :3], w[i, 3:]))
        tau[i] = pin.rnea(model, data, q[i], v[i], a[i], fext)
        if free:
            R = data.oMi[1].rotation
            res_f[i], res_m[i] = R @ tau[i, :3], R @ tau[i, 3:6]
    return InverseDynamics(time, q, v, a, tau, res_f, res_m, joint_labels(model),
                           {k: w for k, (_, w) in wrenches.items()}, carried)  # fmt: skip


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
    model = h.model
    if body in ("left", "right"):
        return model.frames[h.sole_id(body)].parentJoint
    if model.existFrame(body):
        return model.frames[model.getFrameId(body)].parentJoint
    raise HumanoidError(
        f"a load is applied to {body!r}, which {h.source} does not have (a foot: 'left', "
        "'right', or a frame name)"
    )
