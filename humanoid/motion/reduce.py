"""Residual reduction: a motion made consistent with its ground forces before it is tracked.

Measured kinematics and ground forces never agree exactly: marker noise, soft tissue, a
model's segment masses and a trunk's mass centre a few centimetres off leave a **residual**
at the pelvis (the force and moment that nothing in the model provides:
:mod:`~humanoid.motion.inverse_dynamics`). OpenSim's Residual Reduction Algorithm (RRA) and
Moco's tracking problems remove it by changing the motion a little and the model's mass
properties a little; so does :func:`reduce_residuals`, in two steps:

1. **Mass properties** (with measured loads only: estimated loads are fitted to the model's
   mass, which they cannot then correct): the body's total mass (every segment's scaled by
   one factor) and its trunk's mass centre (the upper trunk's segment; forward and sideways)
   that make the trial's mean residual smallest, in the least-squares sense (the residual is
   linear in mass, and in mass times position), as RRA changes the mass from the mean
   vertical residual and the torso's centre from the mean moments; over the frames whose
   loads carry half the body's weight or more (plates that miss steps would make it light).
   Changes are reported; the mass changes by 20 % at most, the trunk's centre moves at most
   ``com_limit``.
2. **Kinematics**: every coordinate of every frame changes by ``dq`` (in the configuration's
   tangent space) to minimise, over the trial,

   ``sum_k |dq_k / sigma_q|^2 + |r_k(q + dq) / sigma_r|^2 + |ddq_k / sigma_a|^2``

   where ``r_k`` is frame k's root residual (force over ``sigma_force`` times body weight,
   moment over ``sigma_moment`` times body weight times metres), ``ddq_k`` the change's
   second difference (smoothness), and ``sigma_q`` per coordinate the change that costs as
   much as that residual: the root's position ``sigma_root`` [m], its orientation and the
   trunk's joints ``sigma_trunk`` [rad], every other joint ``sigma_joint`` [rad]; plus, for
   every load body that carries over 10 % of the weight in frame k (a standing foot), its
   height's and its tilt's drift from the motion before, over ``sigma_contact`` [m] (the
   tilt times 0.1 m): the feet stay on the floor they stood on, and the change goes into the
   joints above them (a pelvis lowered 3 cm under the root's sigma alone would put the
   feet through the floor, which no tracking on that floor can follow). A
   Gauss-Newton iteration: the residual is linearised about the current motion per frame
   (Pinocchio's analytical RNEA derivatives; the acceleration's and velocity's dependence on
   neighbouring frames by the finite differences inverse dynamics uses), the sparse normal
   equations solved for all frames together, the motion updated on the configuration's Lie
   group and differentiated again.

The loads stay as measured (or as estimated once, from the motion before reduction): they
act where they acted. The result (:class:`Reduction`) has the motion before and after, the
residuals before and after, the mass changes and the largest coordinate changes.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Any

import numpy as np
import pinocchio as pin

from ..errors import InverseDynamicsError
from .inverse_dynamics import derivatives, inverse_dynamics, joint_labels, load_frame
from .loads import Load

__all__ = ["Reduction", "reduce_residuals", "trunk_joint"]

# the mass step changes the body's mass by this fraction at most
MASS_LIMIT = 0.2
# a load body carrying more than this fraction of the body's weight is standing: it is kept
# where the motion before had it (the reduction's feet term)
LOADED = 0.1
# [m per rad] the length that turns a foot's rotation into the contact term's metres
FOOT_LENGTH = 0.1
# the names an upper trunk's joint goes by (the body whose mass centre RRA moves: its torso)
TRUNK_NAMES = ("thoracic", "thorax", "chest", "torso", "back", "spine", "lumbar", "abdomen")


@dataclass
class Reduction:
    """The result of :func:`reduce_residuals`.

    Attributes:
        time: (n,) [s]. q_before, q: The motion before and after (n, nq), on the uniform grid,
            filtered as inverse dynamics filters it. residual_before, residual: (n, 6) root
            residuals before and after: force [N], then moment [N m] about the root's origin,
            in world axes. mass_before, mass: The body's total mass [kg]. trunk: The joint
            whose body's mass centre was moved (or None). com_shift: (3,) [m] its change (in
            that body's frame). change: {label: RMS change} of the coordinates ([m] for the
            root's position, [rad] otherwise), the largest first. iterations: Gauss-Newton
            iterations run. model: The Pinocchio model with the mass changes. weight: [N].
            translations: The labels of ``change`` that are the root's position. loads: The
            loads as the reduction applied them (on ``time``, filtered as the motion): inverse
            dynamics of ``q`` under them, unfiltered, gives ``residual``.
    """

    time: np.ndarray
    q_before: np.ndarray
    q: np.ndarray
    residual_before: np.ndarray
    residual: np.ndarray
    mass_before: float
    mass: float
    trunk: str | None
    com_shift: np.ndarray
    change: dict = field(default_factory=dict)
    iterations: int = 0
    model: pin.Model | None = None
    weight: float = 0.0
    translations: tuple = ()
    loads: list = field(default_factory=list)

    def force_rms(self, after: bool = True) -> float:
        """The residual force's RMS [N] after (or before) the reduction."""
        r = self.residual if after else self.residual_before
        return float(np.sqrt(np.mean(np.sum(r[:, :3] ** 2, axis=1))))

    def moment_rms(self, after: bool = True) -> float:
        """The residual moment's RMS [N m] after (or before) the reduction."""
        r = self.residual if after else self.residual_before
        return float(np.sqrt(np.mean(np.sum(r[:, 3:] ** 2, axis=1))))

    def summary(self) -> list[str]:
        """Lines for a report: residuals before and after, mass changes, largest changes."""
        w = self.weight
        lines = [
            f"force RMS {self.force_rms(False):.1f} -> {self.force_rms():.1f} N "
            f"({self.force_rms(False) / w * 100:.1f} -> {self.force_rms() / w * 100:.1f} % BW); "
            f"moment RMS {self.moment_rms(False):.1f} -> {self.moment_rms():.1f} N m"
        ]
        if self.mass != self.mass_before or np.any(self.com_shift):
            shift = ", ".join(f"{x * 1e3:+.1f}" for x in self.com_shift)
            lines.append(f"mass {self.mass_before:.2f} -> {self.mass:.2f} kg; {self.trunk} "
                         f"mass centre moved ({shift}) mm")  # fmt: skip
        big = list(self.change.items())[:4]
        lines.append("changed most (RMS): " + ", ".join(
            f"{k} {v * 1e3:.1f} mm" if k in self.translations else f"{k} {math.degrees(v):.2f} deg"
            for k, v in big))  # fmt: skip
        return lines


def _name(loads, body: str) -> str:
    """The name of the loads on ``body`` (``"estimated"`` stays estimated)."""
    return next((x.name for x in loads if x.body == body), "")


def trunk_joint(model) -> int | None:
    """The joint of a model's upper trunk (by name: thoracic, chest, torso, ... lumbar), whose
    body's mass centre the reduction moves; None if there is none."""
    names = [n.lower() for n in model.names]
    for key in TRUNK_NAMES:
        for j, n in enumerate(names):
            if j > 1 and key in n:
                return j
    return None


def _world_loads(loads_by_body: dict, n: int) -> np.ndarray:
    """The loads' total wrench about the world origin (n, 6)."""
    total = np.zeros((n, 6))
    for w in loads_by_body.values():
        total += w
    return total


def _root_residual(model, data, q, v, a, wrench) -> np.ndarray:
    """The root's residual in its own frame (6,): RNEA's root rows minus the loads' wrench
    (about the world origin, world axes) seen in the root's frame."""
    tau = pin.rnea(model, data, q, v, a)[:6]
    f = _root_placement(model, q).actInv(pin.Force(wrench[:3], wrench[3:]))
    return tau - f.vector


def _root_placement(model, q) -> pin.SE3:
    """The free-flyer root's placement in the world (RNEA does not leave it in the data)."""
    return model.jointPlacements[1] * pin.XYZQUATToSE3(q[:7])


def _residuals(model, q, v, a, W) -> np.ndarray:
    """Per frame, the root residual in world axes (force, then moment about the root)."""
    data = model.createData()
    out = np.empty((len(q), 6))
    for k in range(len(q)):
        r = _root_residual(model, data, q[k], v[k], a[k], W[k])
        R = _root_placement(model, q[k]).rotation
        out[k] = np.concatenate([R @ r[:3], R @ r[3:]])
    return out


def _with_mass(model, trunk: int | None, scale: float, shift) -> pin.Model:
    """A copy of ``model`` with every mass times ``scale`` and the trunk body's mass centre
    moved by ``shift`` (3,) [m, its frame]."""
    out = pin.Model(model)
    for j in range(1, out.njoints):
        I = out.inertias[j]
        lever = np.asarray(I.lever) + (np.asarray(shift) if j == trunk else 0.0)
        # the rotational inertia about the mass centre, scaled with the mass
        out.inertias[j] = pin.Inertia(I.mass * scale, lever, I.inertia * scale)
    return out


def _mass_step(model, q, v, a, W, trunk, sigma_f, sigma_m, com_limit):
    """Step 1, as RRA: the mass scale and the trunk's mass-centre shift (forward and sideways,
    in its body's frame) that make the trial's mean residual smallest (linear least squares;
    the residual is affine in them). The mean: what a body's mass properties change in every
    frame alike, where marker noise and soft tissue average out. Over the frames whose loads
    carry at least half the body's weight (plates that miss a step would otherwise make the
    body light: a walk with plates under 1 s of its 2.3 s came out at a third of its mass),
    the scale kept within :data:`MASS_LIMIT`."""
    weight = float(np.linalg.norm(model.gravity.linear)) * sum(
        model.inertias[j].mass for j in range(1, model.njoints))  # fmt: skip
    carried = W[:, 2] > 0.5 * weight
    if carried.sum() < 3:
        return 1.0, np.zeros(3)
    q, v, a, W = q[carried], v[carried], a[carried], W[carried]
    base = _residuals(model, q, v, a, W).mean(axis=0)
    params = [(1.01, np.zeros(3))]
    if trunk:
        params += [(1.0, np.array([0.01, 0.0, 0.0])), (1.0, np.array([0.0, 0.01, 0.0]))]
    cols = [(_residuals(_with_mass(model, trunk, scale, shift), q, v, a, W).mean(axis=0) - base)
            / 0.01 for scale, shift in params]  # fmt: skip
    A = np.stack(cols, axis=1)
    s = np.r_[[sigma_f] * 3, [sigma_m] * 3]
    x, *_ = np.linalg.lstsq(A / s[:, None], -base / s, rcond=None)
    scale = float(np.clip(1.0 + float(x[0]), 1.0 - MASS_LIMIT, 1.0 + MASS_LIMIT))
    shift = np.zeros(3)
    if trunk:
        shift[:2] = x[1:3]
        norm = float(np.linalg.norm(shift))
        if norm > com_limit:
            shift *= com_limit / norm
    return scale, shift


@dataclass(frozen=True)
class _Feet:
    """The loaded bodies (standing feet) and how the motion before had them: ``frames``
    (the loads' frames), ``loaded`` (n, frames) bool, ``before`` (n, frames) SE3 placements,
    ``sigma`` (6,) the drift [m, rad] that costs as much as one sigma of change."""

    frames: list
    loaded: np.ndarray
    before: list
    sigma: np.ndarray

    # the rows held where the motion before had them: height, and the tilts about the world's
    # horizontal axes. Not the horizontal place: a marker cluster's wobble, taken out, moves
    # the whole body; and not held still from frame to frame (measured on a hemiparetic walk
    # at 30 Hz, scripts/pathological.py: 4 of 5 seeds lost the motion so, 2 of 5 without:
    # a foot rolling off its toes carries load while its frame moves)
    HELD = [2, 3, 4]

    def terms(self, model, q, jacobians: bool = False) -> list[tuple[int, Any, np.ndarray]]:
        """The feet term's rows at the motion ``q`` (n, nq), scaled by sigma: per standing
        body and frame k, (k, its rows' Jacobian (world axes) if ``jacobians`` else None, its
        drift in height and tilt from before)."""
        data = model.createData()
        out = []
        for k in np.flatnonzero(self.loaded.any(axis=1)):
            pin.forwardKinematics(model, data, q[k])
            for b in np.flatnonzero(self.loaded[k]):
                f = self.frames[b]
                now, was = pin.updateFramePlacement(model, data, f), self.before[k][b]
                d = np.concatenate([now.translation - was.translation,
                                    pin.log3(now.rotation @ was.rotation.T)])  # fmt: skip
                d /= self.sigma
                J = None
                if jacobians:
                    J = pin.computeFrameJacobian(model, data, q[k], f, pin.LOCAL_WORLD_ALIGNED)
                    J = (J / self.sigma[:, None])[self.HELD]
                out.append((int(k), J, d[self.HELD]))
        return out


def _standing_feet(h, model, q0, loads_by_body: dict, weight: float, sigma: float) -> _Feet:
    """The feet term's bodies: each load's frame, loaded where it carries more than
    :data:`LOADED` of the weight, and its placements in the motion before (``q0``)."""
    bodies = list(loads_by_body)
    frames = [load_frame(h, b) for b in bodies]
    n = len(q0)
    loaded = np.zeros((n, len(bodies)), dtype=bool)
    for i, b in enumerate(bodies):
        loaded[:, i] = loads_by_body[b][:, 2] > LOADED * weight
    data = model.createData()
    before = []
    for k in range(n):
        pin.framesForwardKinematics(model, data, q0[k])
        before.append([data.oMf[f].copy() for f in frames])
    return _Feet(frames, loaded, before, np.r_[[sigma] * 3, [sigma / FOOT_LENGTH] * 3])


def _cost(model, q, v, a, W, changed, dt, sq, sr, sa, feet: _Feet) -> float:
    """The reduction's objective (module docstring) at the motion ``q`` (its ``v``, ``a``),
    ``changed`` from the motion before."""
    r = _residuals(model, q, v, a, W)  # (world axes: the sigmas are the same on each axis)
    smooth = (changed[:-2] - 2 * changed[1:-1] + changed[2:]) / dt**2 / sa
    stand = sum(float(d @ d) for _, _, d in feet.terms(model, q))
    return float(np.sum((r / sr) ** 2) + np.sum((changed / sq) ** 2) + np.sum(smooth**2)) + stand


def _sigmas(model, sigma_root, sigma_trunk, sigma_joint) -> np.ndarray:
    """Per generalised velocity, the change that costs as much as the residual's sigma."""
    s = np.full(model.nv, sigma_joint)
    s[:3], s[3:6] = sigma_root, sigma_trunk
    for j in range(2, model.njoints):
        n = model.names[j].lower()
        if any(k in n for k in TRUNK_NAMES):
            i, nv = model.joints[j].idx_v, model.joints[j].nv
            s[i : i + nv] = sigma_trunk
    return s


def _kinematic_step(model, q, v, a, W, dt, sq, sr, sa, changed, feet: _Feet):
    """One Gauss-Newton step on all frames: the tangent change dq (n, nv) to add to the
    motion ``q``, which is ``changed`` (n, nv) from the motion before the reduction (the cost's
    change and smoothness terms are on the whole change, ``changed + dq``)."""
    from scipy import sparse
    from scipy.sparse.linalg import spsolve

    n, nv = len(q), model.nv
    data = model.createData()
    rows, cols, vals = [], [], []
    rhs = []
    row = 0

    def put(r0, c_frame, block):
        if 0 <= c_frame < n:
            ii, jj = np.nonzero(np.abs(block) > 0)
            rows.extend(r0 + ii)
            cols.extend(c_frame * nv + jj)
            vals.extend(block[ii, jj])

    for k in range(n):
        kk = min(max(k, 1), n - 2)  # the stencil the first and last samples' derivatives use
        pin.computeRNEADerivatives(model, data, q[k], v[k], a[k])
        dq_, dv_ = data.dtau_dq[:6].copy(), data.dtau_dv[:6].copy()
        Mfull = np.triu(data.M) + np.triu(data.M, 1).T
        da_ = Mfull[:6]
        r = _root_residual(model, data, q[k], v[k], a[k], W[k])
        # the loads' part depends on the root's placement: by finite differences
        for i in range(6):
            e = np.zeros(nv)
            e[i] = 1e-6
            qi = pin.integrate(model, q[k], e)
            dq_[:, i] = (_root_residual(model, data, qi, v[k], a[k], W[k]) - r) / 1e-6
        Aq = dq_ / sr[:, None]
        Bv = dv_ / sr[:, None] / (2 * dt)
        Ca = da_ / sr[:, None] / dt**2
        put(row, k, Aq)
        if kk == k:
            put(row, k + 1, Bv + Ca)
            put(row, k - 1, -Bv + Ca)
            put(row, k, -2 * Ca)
        else:
            put(row, kk + 1, Ca)
            put(row, kk - 1, Ca)
            put(row, kk, -2 * Ca)
            if k == 0:
                put(row, 1, 2 * Bv)
                put(row, 0, -2 * Bv)
            else:
                put(row, n - 1, 2 * Bv)
                put(row, n - 2, -2 * Bv)
        rhs.append(-r / sr)
        row += 6
    # the standing feet kept on the floor they stood on
    for k, Jk, d in feet.terms(model, q, jacobians=True):
        put(row, k, Jk)
        rhs.append(-d)
        row += len(d)
    # the change itself
    idx = np.arange(n * nv)
    rows.extend(row + idx)
    cols.extend(idx)
    vals.extend(np.tile(1.0 / sq, n))
    rhs.append(-(changed / sq).reshape(-1))
    row += n * nv
    # its smoothness
    for k in range(1, n - 1):
        for off, c in ((-1, 1.0), (0, -2.0), (1, 1.0)):
            rows.extend(row + np.arange(nv))
            cols.extend((k + off) * nv + np.arange(nv))
            vals.extend(np.full(nv, c / dt**2 / sa))
        rhs.append(-(changed[k - 1] - 2 * changed[k] + changed[k + 1]) / dt**2 / sa)
        row += nv
    J = sparse.csr_matrix((vals, (rows, cols)), shape=(row, n * nv))
    b = np.concatenate(rhs)
    x = spsolve((J.T @ J).tocsc(), J.T @ b)
    return np.asarray(x).reshape(n, nv)


def _gauss_newton(model, t, dt: float, q0, v0, a0, W, sq, sr, sigma_acceleration: float,
                  iterations: int, feet: _Feet):  # fmt: skip
    """The kinematic step's Gauss-Newton iterations from the motion ``q0`` (n, nq) at ``t``:
    (q, v, a, the change from q0 (n, nv), the iterations that lowered the cost)."""
    qk, vk, ak = q0, v0, a0
    done = 0
    changed = np.zeros((len(t), model.nv))
    cost = _cost(model, qk, vk, ak, W, changed, dt, sq, sr, sigma_acceleration, feet)
    for _ in range(iterations):
        dq = _kinematic_step(model, qk, vk, ak, W, dt, sq, sr, sigma_acceleration, changed, feet)
        for step in (1.0, 0.5, 0.25, 0.125):  # backtracking: the linearisation can overshoot
            total = np.array(
                [pin.integrate(model, x, step * d) for x, d in zip(qk, dq, strict=True)]
            )
            _, q1, v1, a1 = derivatives(model, t, total, cutoff=None)
            moved = np.array([pin.difference(model, a_, b_) for a_, b_ in zip(q0, q1, strict=True)])
            new = _cost(model, q1, v1, a1, W, moved, dt, sq, sr, sigma_acceleration, feet)
            if new < cost:
                break
        else:
            break  # no step lowers the cost: converged, or the linearisation is no guide
        qk, vk, ak, changed, cost = q1, v1, a1, moved, new
        done += 1
        if np.max(np.abs(step * dq) / sq) < 1e-3:
            break
    return qk, vk, ak, changed, done


def reduce_residuals(h, time, q, loads: list[Load] | tuple, *, cutoff: float | None = 6.0,
                     adjust_mass: bool | None = None, sigma_force: float = 0.01,
                     sigma_moment: float = 0.002, sigma_root: float = 0.01,
                     sigma_trunk: float = math.radians(2.0), sigma_joint: float = math.radians(1.0),
                     sigma_acceleration: float = 50.0, sigma_contact: float = 0.002,
                     com_limit: float = 0.05, iterations: int = 4) -> Reduction:  # fmt: skip
    """The motion ``q`` (n, nq) at ``time`` (n,), under ``loads``, changed a little (and the
    body's mass properties) so that its root residuals are small (see the module docstring).

    Args:
        h: The :class:`~humanoid.model.Humanoid`. loads: The ground forces (measured, or
            :func:`~humanoid.motion.inverse_dynamics.estimate_loads`'s).
        cutoff: The motion's and the loads' low-pass cutoff [Hz], as in inverse dynamics.
        adjust_mass: Step 1 (mass and trunk mass centre); default: with measured loads (any
            load not named ``"estimated"``).
        sigma_force, sigma_moment: The residual force [body weights] and moment [body
            weights times metres] that cost as much as one ``sigma_*`` of change.
        sigma_root: [m] the root's position; sigma_trunk: [rad] the root's orientation and the
            trunk's joints; sigma_joint: [rad] every other joint; sigma_acceleration: the
            change's second derivative [rad/s^2, m/s^2] (smoothness).
        sigma_contact: [m] a standing foot's drift in height from the motion (its tilt
            times 0.1 m) that costs as much: a load body carrying over 10 % of the weight
            stays on the floor it stood on.
        com_limit: [m] the trunk's mass centre moves at most this far. iterations: Gauss-Newton
            iterations.

    Raises:
        InverseDynamicsError: a body without a free-flyer root, no loads, or a sigma that is
            not a positive number.
    """
    sigmas = {"sigma_force": sigma_force, "sigma_moment": sigma_moment,
              "sigma_root": sigma_root, "sigma_trunk": sigma_trunk, "sigma_joint": sigma_joint,
              "sigma_acceleration": sigma_acceleration, "sigma_contact": sigma_contact}  # fmt: skip
    for name, value in sigmas.items():
        if (
            isinstance(value, bool)
            or not isinstance(value, int | float)
            or not (math.isfinite(value) and value > 0)
        ):
            raise InverseDynamicsError(f"{name} must be a positive number, got {value!r}")
    model0 = h.model
    if "FreeFlyer" not in model0.joints[1].shortname():
        raise InverseDynamicsError("residual reduction needs a body with a free-flyer root")
    if not loads:
        raise InverseDynamicsError(
            "residual reduction needs the motion's ground forces (measured or estimated)"
        )
    before = inverse_dynamics(h, time, q, loads, cutoff=cutoff)
    t, q0 = before.time, before.q
    W = _world_loads(before.loads, len(t))
    dt = float(t[1] - t[0])
    weight = h.mass * float(np.linalg.norm(model0.gravity.linear))
    sr = np.r_[[sigma_force * weight] * 3, [sigma_moment * weight] * 3]
    res_before = np.hstack([before.residual_force, before.residual_moment])
    if adjust_mass is None:
        adjust_mass = any(x.name != "estimated" for x in loads)
    trunk = trunk_joint(model0)
    scale, shift = 1.0, np.zeros(3)
    model = model0
    if adjust_mass:
        scale, shift = _mass_step(model0, q0, before.v, before.a, W, trunk, sr[0], sr[3],
                                  com_limit)  # fmt: skip
        model = _with_mass(model0, trunk, scale, shift)
    sq = _sigmas(model, sigma_root, sigma_trunk, sigma_joint)
    feet = _standing_feet(h, model, q0, before.loads, weight, sigma_contact)
    qk, vk, ak, changed, done = _gauss_newton(model, t, dt, q0, before.v, before.a, W, sq, sr,
                                              sigma_acceleration, iterations, feet)  # fmt: skip
    res = _residuals(model, qk, vk, ak, W)
    diff = changed
    labels = joint_labels(model, root=("x", "y", "z", "rx", "ry", "rz"))
    rms = np.sqrt(np.mean(diff**2, axis=0))
    order = np.argsort(-rms / sq)
    change = {labels[i]: float(rms[i]) for i in order}
    return Reduction(t, q0, qk, res_before, res, h.mass, h.mass * scale,
                     model0.names[trunk] if trunk else None, shift, change, done, model,
                     weight, tuple(labels[:3]),
                     [Load.from_wrench(body, t, w, name=_name(loads, body))
                      for body, w in before.loads.items()])  # fmt: skip
