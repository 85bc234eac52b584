"""A walk as a simulation: the plan and controller drive the project's constrained dynamics.

The walk is three plug-ins of the one run loop (:meth:`humanoid.simulation.Simulation.run`):

- :class:`FootstepSchedule`, the contact schedule: the plan says which feet are on the ground
  (``Simulation.switch_contacts``); a foot that leaves it is released (the controller has moved
  its load away during double support), a foot that lands is welded where it is with the
  impulse that stops it;
- the :class:`~humanoid.walking.controller.WalkingController`, which solves its QP at every
  control tick and holds its joint torques;
- :class:`WalkMonitor`, which after every step computes the acceptance checks on the simulated
  state and forces, keeps them as time series, and stops the run at a fall.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np
import pinocchio as pin

from ..constraints.limits import JointRanges, range_violations
from ..dynamics import TreeDynamics, centre_of_pressure
from ..errors import RunFailed, WalkError
from ..linalg import cross
from ..model import SIDES, Humanoid
from ..scene import Contact, Effects, Initial, Scene, Stabilisation
from ..simulation import Simulation, StepResult, Trajectory
from .controller import ControllerGains, WalkingController
from .plan import FootstepPlan, GaitParameters
from .preview import com_trajectory

__all__ = [
    "CONTROL_PERIOD",
    "FootstepSchedule",
    "WalkMonitor",
    "WalkResult",
    "WalkSetup",
    "crouch",
    "prepare",
    "walk",
]

COP_MIN_LOAD = 0.01  # [body weights] below this a foot's centre of pressure is not checked
# The controller's QP period [s]; between QP ticks the contact forces are held
# (WalkingController.held_torques). Measured on the male, female and erd human bodies' 10-step
# walks (scripts/walk_periods.py): every check passes up to 12 ms (the female's ranges fail at
# 14 ms, the one-piece-feet male falls at 12 ms); g1's walk (marginal at 1 ms, its CoM 3.6 cm
# off its reference) passes at 3 ms and falls from 4 ms.
CONTROL_PERIOD = 8e-3

# Typical adult gait (Bohannon 1997, Murray 1964/1970, Perry & Burnfield, Winter, Powers 2002,
# Cooper 2008).
HUMAN = {
    "speed": "1.27-1.46 m/s",
    "step_length": "0.66-0.79 m",
    "cadence": "100-120 steps/min",
    "double_support": "~20 % of the cycle",
    "peak_vertical_grf": "1.1-1.2 BW",
    "peak_friction": "0.17-0.25",
    "com_vertical_excursion": "4-5 cm",
}


@dataclass(frozen=True)
class WalkResult:
    """A simulated walk: the trajectory, the per-tick checks, and the gait summary."""

    trajectory: Trajectory
    checks: dict
    summary: dict
    series: dict = field(default_factory=dict)

    @property
    def ok(self) -> bool:
        return all(c["ok"] for c in self.checks.values())


def crouch(h: Humanoid, drop: float, forward: float = 0.0) -> np.ndarray:
    """The standing configuration with the pelvis lowered by ``drop`` [m] (and moved forward),
    the soles flat where they were: leg inverse kinematics (each leg's 6 joints against its
    sole's 6D placement, Gauss-Newton)."""
    model = h.model
    data = model.createData()
    q = h.standing_configuration()
    pin.framesForwardKinematics(model, data, q)
    targets = {s: data.oMf[h.sole_id(s)].copy() for s in SIDES}
    q[2] -= drop
    q[0] += forward
    inside = math.radians(5.0)  # hinges standing on a limit (straight elbows) move inside it
    for jm in model.joints[2:]:
        if jm.nq == 1:
            lo, hi = model.lowerPositionLimit[jm.idx_q], model.upperPositionLimit[jm.idx_q]
            if hi - lo > 4 * inside:
                q[jm.idx_q] = np.clip(q[jm.idx_q], lo + inside, hi - inside)
    for j in range(2, model.njoints):  # start the leg IK on the flexed branch of the knees
        jm = model.joints[j]
        if "knee" in model.names[j].lower() and jm.nq == 1:
            lo, hi = model.lowerPositionLimit[jm.idx_q], model.upperPositionLimit[jm.idx_q]
            q[jm.idx_q] = 0.3 if hi >= 0.3 else max(lo, -0.3)
    for _ in range(100):
        pin.computeJointJacobians(model, data, q)
        pin.updateFramePlacements(model, data)
        errs, rows = [], []
        for s in SIDES:
            fid = h.sole_id(s)
            err = targets[s].actInv(data.oMf[fid])
            errs.append(pin.log6(err).vector)
            rows.append(
                pin.Jlog6(err) @ pin.getFrameJacobian(model, data, fid, pin.ReferenceFrame.LOCAL)
            )
        e = np.concatenate(errs)
        if np.abs(e).max() < 1e-12:
            break
        J = np.vstack(rows)
        J[:, :6] = 0.0  # the pelvis stays where it was put
        dq = -J.T @ np.linalg.solve(J @ J.T + 1e-6 * np.eye(len(e)), e)  # damped least squares
        q = pin.integrate(model, q, dq)
    else:
        raise WalkError(f"cannot lower the pelvis by {drop} m with the soles flat")
    for jm in model.joints[2:]:
        if jm.nq == 1:
            lo, hi = model.lowerPositionLimit[jm.idx_q], model.upperPositionLimit[jm.idx_q]
            if not lo - 1e-9 <= q[jm.idx_q] <= hi + 1e-9:
                raise WalkError(
                    f"lowering the pelvis by {drop} m puts {model.names[jm.id]} out of its limits"
                )
    return q


@dataclass
class WalkSetup:
    """A walk made ready to run: its plan, crouched start, plant and controller."""

    plan: FootstepPlan
    q0: np.ndarray
    v0: np.ndarray  # the initial velocity, consistent with the stance welds
    soles: dict  # initial sole positions by side
    scene: Scene
    sim: Simulation  # the plant (and the stance welds' bookkeeping)
    ctl: WalkingController
    schedule: FootstepSchedule
    t_ref: np.ndarray
    c_ref: np.ndarray
    zmp: np.ndarray

    def run(self, quiet: bool = False, monitors=()) -> Trajectory:
        """The walk: the plant driven by the controller along the plan's footsteps."""
        return self.sim.run(quiet=quiet, controller=self.ctl, schedule=self.schedule,
                            monitors=monitors)  # fmt: skip


def prepare(h, gait, dt=1e-3, mu=0.8, drop=0.04, gains=None, integrator="semi_implicit_euler",
            record_rate=100.0, rtol=1e-6, atol=1e-6) -> WalkSetup:  # fmt: skip
    """The plan from the crouched start, the preview-control CoM reference, the plant (both
    feet welded where they stand, Baumgarte 20 dt, attached at t = 0) and the controller that
    drives it."""
    model = h.model
    q0 = crouch(h, drop)
    data = model.createData()
    pin.framesForwardKinematics(model, data, q0)
    soles = {s: data.oMf[h.sole_id(s)].translation.copy() for s in SIDES}
    plan = FootstepPlan(gait, soles["left"][:2], soles["right"][:2])
    c0 = pin.centerOfMass(model, data, q0)
    feet = tuple(Contact(s, "weld", mu=mu) for s in SIDES)
    scene = Scene(
        name="walk", body=h.source, ball_joints=h.ball_joints, duration=plan.duration, dt=dt,
        integrator=integrator, rtol=rtol, atol=atol, record_rate=record_rate,
        initial=Initial(configuration=tuple(q0)), effects=Effects(contacts=feet),
        stabilisation=Stabilisation(baumgarte=20.0),
    )  # fmt: skip
    sim = Simulation(scene, humanoid=h)
    t_ref, c_ref, dc_ref, ddc_ref, _, zmp_ref = com_trajectory(plan, c0[2], c0[:2])
    ctl = WalkingController(
        h, sim.model, plan, (t_ref, c_ref, dc_ref, ddc_ref), c0[2], q0, sim.baumgarte,
        gains or ControllerGains(mu=min(0.6, 0.75 * mu)), period=dt,
    )  # fmt: skip
    schedule = FootstepSchedule(plan, sim.n_steps)
    v0 = sim.update_contacts(0.0, q0, np.zeros(model.nv))  # both feet welded where they stand
    return WalkSetup(plan, q0, v0, soles, scene, sim, ctl, schedule, t_ref, c_ref, zmp_ref)


def walk(
    h: Humanoid,
    gait: GaitParameters | None = None,
    dt: float = 1e-3,
    mu: float = 0.8,
    drop: float = 0.04,
    gains: ControllerGains | None = None,
    quiet: bool = False,
    record_rate: float = 100.0,
    integrator: str = "semi_implicit_euler",
    control_dt: float | None = None,
    rtol: float = 1e-6,
    atol: float = 1e-6,
    hold: str = "forces",
) -> WalkResult:
    """Walk ``h`` along a straight plan in forward simulation.

    Args:
        h: The humanoid (quaternion ball joints recommended).
        gait: Steps, step length and timing.
        dt: Simulation and control step [s].
        mu: Friction coefficient of the checks (the controller uses a smaller one).
        drop: How far the pelvis is lowered from standing before walking [m] (bent knees).
        gains: Controller gains.
        quiet: No progress bar.
        record_rate: Records per second in the trajectory [Hz].
        integrator: The simulator's integrator (semi-implicit Euler by default).
        control_dt: The QP's period [s], a whole number of steps (default ``CONTROL_PERIOD``,
            8 ms, or every step if dt is longer). Between QP ticks the contact forces are held
            and the torques follow the state (``WalkingController.held_torques``); the
            consistency check runs on QP ticks.
        rtol, atol: Tolerances of the adaptive integrator (``integrator="adaptive"``), which
            chooses its own steps inside each step of ``dt`` (the contacts switch, and the
            checks run, at multiples of ``dt``).
        hold: Between QP ticks, ``"forces"`` (the contact forces held, the torques following
            the state) or ``"torques"`` (the torques held: a sampled controller, as the
            accuracy benchmark compares integrators under).
    """
    if hold not in ("forces", "torques"):
        raise WalkError(f"hold must be 'forces' or 'torques', got {hold!r}")
    gait = gait or GaitParameters()
    setup = prepare(h, gait, dt, mu, drop, gains, integrator, record_rate, rtol, atol)
    plan, sim, ctl, soles = setup.plan, setup.sim, setup.ctl, setup.soles
    ctl.every = max(1, int(round((control_dt or CONTROL_PERIOD) / dt)))
    ctl.period = ctl.every * dt
    ctl.hold = hold
    monitor = WalkMonitor(h, sim, ctl)
    traj = setup.run(quiet=quiet, monitors=[monitor])
    meta = traj.metadata
    status, message, n = meta["status"], meta["message"], meta["steps"]
    series = monitor.series_until(n)
    series["impulse"] = setup.schedule.impulse[:n]
    weight = monitor.weight
    meta.update({
        "gait": {f: getattr(gait, f) for f in gait.__dataclass_fields__},
        "footsteps": [[s.side, *s.target.tolist(), s.t_lift, s.t_land] for s in plan.steps],
        "initial_soles": {s: soles[s].tolist() for s in SIDES},
        "weight": weight,
        "control_period": ctl.period,
        "sole_size": [float(x) for x in sim.contacts[0].cop_box[1] - sim.contacts[0].cop_box[0]],
    })  # fmt: skip
    checks = _acceptance(series, plan, status, message, weight, mu)
    summary = _summary(series, plan, gait, weight, status, meta["wall_time"], n * dt)
    series["zmp_ref"] = setup.zmp
    series["t_ref"] = setup.t_ref
    series["com_ref"] = setup.c_ref
    return WalkResult(traj, checks, summary, series)


class FootstepSchedule:
    """The walk's contact schedule: the feet on the ground are those the plan says; the
    largest velocity change of each touchdown's impulse is kept by tick (``impulse``)."""

    def __init__(self, plan: FootstepPlan, n_steps: int) -> None:
        self.plan = plan
        self.impulse = np.full(n_steps, np.nan)

    def __call__(self, sim: Simulation, k: int, t: float, q, v, last) -> np.ndarray:
        v_new = sim.switch_contacts(t, q, v, self.plan.stance(t))  # lift-off and touchdown
        if v_new is not v and k < len(self.impulse):
            self.impulse[k] = float(np.abs(v_new - v).max())
        return v_new


SERIES = (
    "t", "pelvis_z", "tilt", "consistency", "drift", "fz_left", "fz_right", "friction",
    "cop_margin", "com_x", "com_y", "com_z", "com_ref_x", "com_ref_y", "zmp_x", "zmp_y",
    "tau_base", "range",
)  # fmt: skip
# x^2 + y^2 of the pelvis' quaternion under this: its tilt is under 28.4 deg, no fall to test
TILT_GUARD = 0.06
KINEMATICS_BATCH = 256  # states per TreeDynamics call (its outputs stay in the cache)


class WalkMonitor:
    """The walk's checks at every tick, from the plant's own solve, as time series; a fall
    (pelvis below 80 % of its start height, or the trunk tilted over 30 degrees) stops the run.

    During the run each tick keeps only what the checks need and cannot get back later (the
    state, the plant's contact forces and which welds they belong to, the controller's base
    torques and, on control ticks, the controller's accelerations against the plant's) and
    tests for a fall; the series (trunk tilt, centre of mass, feet wrenches, friction, centres
    of pressure, weld drift, zero-moment point, joint ranges) are computed from those after
    the run, for all ticks at once (:meth:`series_until`), the same numbers at every tick for
    a fraction of the cost.
    """

    def __init__(self, h: Humanoid, sim: Simulation, ctl: WalkingController) -> None:
        n = sim.n_steps
        self.h, self.sim, self.ctl = h, sim, ctl
        self.ranges = JointRanges(h)
        self.fk = TreeDynamics(sim.model)  # the batch kinematics of series_until
        self.weight = h.mass * 9.81
        self.z_start: float | None = None  # the pelvis' height at the first step [m]
        self.t = np.full(n, np.nan)
        self.q = np.zeros((n, sim.model.nq))
        self.base = np.full((n, 6), np.nan)  # the torques on the free flyer
        # (tick, the plant's accelerations, the QP's) of the ticks the QP was solved at
        self.solves: list[tuple[int, np.ndarray, np.ndarray]] = []
        # the plant's stacked constraint forces, and the index of their layout (-1: none)
        width = sum(con.size for c in sim.contacts for con in c.constraints)
        self.forces = np.full((n, width), np.nan)
        self.layout = np.full(n, -1)
        # each active set's layout: [(side, its weld's first row, its anchor's index)]
        self.layouts: list[list[tuple[str, int, int]]] = []
        self.anchors: list[pin.SE3] = []
        self.welds: dict = {}  # (weld, its anchor's index) of each side, the last seen
        self._active: list | None = None  # the active set of the last layout
        self._index = -1  # its index in layouts

    def _new_layout(self, sim: Simulation, active: list) -> None:
        """A new active set's layout: where each attached foot's weld is in the plant's forces,
        and its anchor's index (a new weld's anchor kept)."""
        rows, i = [], 0
        for c in sim.contacts:
            if c.attached:
                weld = c.constraints[0]
                if self.welds.get(c.side, (None,))[0] is not weld:  # a new weld
                    self.welds[c.side] = (weld, len(self.anchors))
                    self.anchors.append(weld.anchor)
                rows.append((c.side, i, self.welds[c.side][1]))
                i += sum(con.size for con in c.constraints)  # the weld, then its locks
        if i > self.forces.shape[1]:
            wider = np.full((len(self.forces), i), np.nan)
            wider[:, : self.forces.shape[1]] = self.forces
            self.forces = wider
        self._active, self._index = active, len(self.layouts)
        self.layouts.append(rows)

    def observe(self, sim: Simulation, k: int, t: float, q, v, step: StepResult) -> None:
        if self.z_start is None:
            self.z_start = q[2]
        self.t[k] = t
        self.q[k] = q
        self.base[k] = step.torque[:6]
        sol = step.solution
        if sol is not None:
            active = sim.book.active_constraints()
            if active:
                if self.ctl.fresh:  # the QP was solved at this very state
                    self.solves.append((k, sol.a.copy(), self.ctl.last[0].copy()))
                forces = sol.forces
                self.forces[k, : len(forces)] = forces
                if active is not self._active:
                    self._new_layout(sim, active)
                self.layout[k] = self._index
        x, y, z = q[3], q[4], step.q[2]
        if z < 0.8 * self.z_start or not x * x + y * y < TILT_GUARD:
            self._fall(t, x, y, z)

    def _fall(self, t: float, x: float, y: float, z: float) -> None:
        """Stop the run (RunFailed) at a fall: the pelvis (its height z at the step's end)
        below 80 % of its start height, or the trunk (its quaternion's x and y) tilted over 30
        degrees."""
        assert self.z_start is not None
        tilt = math.degrees(math.acos(min(1.0, max(-1.0, 1.0 - 2.0 * (x * x + y * y)))))
        if z < 0.8 * self.z_start or tilt > 30.0:
            raise RunFailed(
                f"fall at t = {t:.3f} s: pelvis {z:.3f} m (start {self.z_start:.3f} m), "
                f"trunk tilt {tilt:.1f} deg"
            )

    def consistency_until(self, n: int) -> np.ndarray:
        """The plant's accelerations against the controller's over the first n ticks: the
        largest difference relative to the largest of the controller's (at least 1), on the
        ticks the QP was solved at (NaN on the others)."""
        out = np.full(n, np.nan)
        solves = [row for row in self.solves if row[0] < n]
        if solves:
            k, a, dv = (np.array(x) for x in zip(*solves, strict=True))
            out[k] = np.abs(a - dv).max(axis=1) / np.fmax(1.0, np.abs(dv).max(axis=1))
        return out

    def wrenches(self, n: int) -> tuple[dict, dict]:
        """Each foot's weld wrench over the first n ticks (n, 6) (LOCAL axes, NaN when not
        attached) and its anchor's index in ``anchors`` (-1 when not attached)."""
        wrench = {c.side: np.full((n, 6), np.nan) for c in self.sim.contacts}
        anchor = {c.side: np.full(n, -1) for c in self.sim.contacts}
        layout = self.layout[:n]
        for index, rows in enumerate(self.layouts):
            ticks = np.flatnonzero(layout == index)
            for side, i, a in rows:
                wrench[side][ticks] = self.forces[ticks, i : i + 6]
                anchor[side][ticks] = a
        return wrench, anchor

    def series_until(self, n: int) -> dict:
        """The checks' time series over the first n ticks (see the class docstring)."""
        sim, weight = self.sim, self.weight
        s = {k: np.full(n, np.nan) for k in SERIES}
        q = self.q[:n]
        s["t"], s["pelvis_z"], s["consistency"] = self.t[:n], q[:, 2], self.consistency_until(n)
        s["tilt"] = _tilt(q[:, 3], q[:, 4])
        s["tau_base"] = np.abs(self.base[:n]).max(axis=1)
        soles = {c.side: c.sole for c in sim.contacts}
        com, rotation, origin = _kinematics(self.fk, sim.model, q, soles)
        s["com_x"], s["com_y"], s["com_z"] = com.T
        s["com_ref_x"], s["com_ref_y"] = _com_reference(self.ctl, s["t"]).T
        s["range"] = np.degrees(range_violations(self.ranges, q))
        wrench, anchor = self.wrenches(n)
        drift = _drift(anchor, self.anchors, rotation, origin)
        total = np.zeros((n, 6))  # the feet's wrench about the world origin
        friction = np.zeros(n)
        margin = np.full(n, np.inf)
        on = np.zeros(n, dtype=bool)
        for c in sim.contacts:
            w = wrench[c.side]  # LOCAL axes, about the sole's origin
            attached = np.isfinite(w[:, 0])
            on |= attached
            R, o = rotation[c.side], origin[c.side]
            f = np.einsum("nij,nj->ni", R, w[:, :3])
            tau = np.einsum("nij,nj->ni", R, w[:, 3:])
            s[f"fz_{c.side}"] = np.where(attached, f[:, 2] / weight, np.nan)
            total[:, :3] += np.where(attached[:, None], f, 0.0)
            total[:, 3:] += np.where(attached[:, None], tau + cross(o, f), 0.0)
            with np.errstate(invalid="ignore", divide="ignore"):
                loaded = attached & (f[:, 2] > 0.2 * weight)
                ratio = np.hypot(f[:, 0], f[:, 1]) / f[:, 2]
                friction = np.maximum(friction, np.where(loaded, ratio, 0.0))
                # the centre of pressure in the sole's own axes (the welds' forces are LOCAL);
                # that of an (almost) unloaded foot is undefined
                cop = centre_of_pressure(w)
                lo, hi = c.cop_box
                inside = np.minimum(np.minimum(cop[:, 0] - lo[0], cop[:, 1] - lo[1]),
                                    np.minimum(hi[0] - cop[:, 0], hi[1] - cop[:, 1]))  # fmt: skip
                margin = np.minimum(margin, np.where(f[:, 2] > COP_MIN_LOAD * weight, inside,
                                                     np.inf))  # fmt: skip
        s["friction"] = np.where(on, friction, np.nan)
        s["cop_margin"] = np.where(on & np.isfinite(margin), margin, np.nan)
        s["drift"] = np.where(on, drift, np.nan)
        zmp = centre_of_pressure(total)
        up = on & (total[:, 2] > 1e-6)  # the zero-moment point: the feet's CoP on the floor
        s["zmp_x"], s["zmp_y"] = np.where(up, zmp[:, 0], np.nan), np.where(up, zmp[:, 1], np.nan)
        return s


def _tilt(x, y) -> np.ndarray:
    """The pelvis' tilt [deg] from its quaternion's x and y: the angle of its z axis from the
    vertical (as WalkMonitor._fall)."""
    return np.degrees(np.arccos(np.clip(1.0 - 2.0 * (x * x + y * y), -1.0, 1.0)))


def _kinematics(fk: TreeDynamics, model: pin.Model, Q, soles: dict) -> tuple:
    """The centre of mass (n, 3) and each sole's world rotation (n, 3, 3) and origin (n, 3) at
    the configurations Q (n, nq): TreeDynamics' compiled forward kinematics, a batch of states
    at a time (Pinocchio's, state by state, without it); the same numbers to 1e-15."""
    n, nj = len(Q), model.njoints
    com = np.empty((n, 3))
    rotation = {side: np.empty((n, 3, 3)) for side in soles}
    origin = {side: np.empty((n, 3)) for side in soles}
    if not fk.available:
        data = model.createData()
        for k in range(n):
            com[k] = pin.centerOfMass(model, data, Q[k])  # (the joints' placements too)
            for side, fid in soles.items():
                M = pin.updateFramePlacement(model, data, fid)
                rotation[side][k], origin[side][k] = M.rotation, M.translation
        return com, rotation, origin
    # the CoM, sum_j m_j (R_j c_j + t_j) / m (the universe left out), as two matrix products
    # with the batch's placements (rows: the states; columns: every R_j and t_j entry)
    mass = np.array([0.0] + [inertia.mass for inertia in model.inertias[1:]])
    lever = np.array([inertia.lever for inertia in model.inertias])
    by_R, by_t = np.zeros((nj, 3, 3, 3)), np.zeros((nj, 3, 3))
    for i in range(3):
        by_R[:, i, :, i], by_t[:, i, i] = mass[:, None] * lever, mass
    by_R, by_t = by_R.reshape(9 * nj, 3) / mass.sum(), by_t.reshape(3 * nj, 3) / mass.sum()
    frames = {side: model.frames[fid] for side, fid in soles.items()}
    zero = np.zeros((KINEMATICS_BATCH, model.nv))
    for a in range(0, n, KINEMATICS_BATCH):
        b = slice(a, min(n, a + KINEMATICS_BATCH))
        m = b.stop - a
        out = fk(Q[b], zero[:m], zero[:m])
        com[b] = out.R.reshape(m, -1) @ by_R + out.t.reshape(m, -1) @ by_t
        for side, frame in frames.items():  # a frame: its joint's placement times its own
            R, t = out.R[:, frame.parentJoint], out.t[:, frame.parentJoint]
            rotation[side][b] = (R.reshape(3 * m, 3) @ frame.placement.rotation).reshape(m, 3, 3)
            origin[side][b] = R @ frame.placement.translation + t
    return com, rotation, origin


def _com_reference(ctl: WalkingController, t) -> np.ndarray:
    """The controller's CoM reference (x, y) at every t (n, 2): ``ctl.com_reference(t)[0][:2]``
    for all t at once, the same interpolation on its uniform table with the same clamping."""
    t_ref, c_ref = ctl.t_ref, ctl.c_ref
    k = np.minimum(np.maximum((t - t_ref[0]) / (t_ref[1] - t_ref[0]), 0.0), len(t_ref) - 1.0)
    i = np.minimum(k.astype(np.int64), len(t_ref) - 2)
    s = (k - i)[:, None]
    return (1.0 - s) * c_ref[i] + s * c_ref[i + 1]


def _drift(anchor: dict, anchors: list, rotation: dict, origin: dict) -> np.ndarray:
    """The largest weld drift of the attached feet at each tick [m] (0 with none): the norm of
    the translation of log6(anchor^-1 M), M the sole's placement."""
    drift = np.zeros(len(next(iter(origin.values()))))
    for side, index in anchor.items():
        for a, A in enumerate(anchors):
            k = np.flatnonzero(index == a)
            if len(k):  # anchor.actInv(M): R_a^T R and R_a^T (p - p_a)
                Rt = rotation[side][k].transpose(0, 2, 1).reshape(-1, 3) @ A.rotation
                p = (origin[side][k] - A.translation) @ A.rotation
                r = _log6_linear(Rt.reshape(-1, 3, 3).transpose(0, 2, 1), p)
                drift[k] = np.maximum(drift[k], np.sqrt(r[0] * r[0] + r[1] * r[1] + r[2] * r[2]))
    return drift


EPS = float(np.finfo(float).eps)
TAYLOR = EPS ** (1.0 / 3.0)  # Pinocchio's TaylorSeriesExpansion<double>::precision<2>()
HALF_TURN = -0.9  # _log6_linear: a rotation whose cosine is below this goes to pin.log6
LOG_BLOCK = 2048  # placements per block of _log6_linear


def _cross(a, b) -> np.ndarray:
    """a x b of vectors stored by component, (3, m)."""
    return np.stack([a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2],
                     a[0] * b[1] - a[1] * b[0]])  # fmt: skip


def _log6_linear(R, p) -> np.ndarray:
    """``pin.log6(SE3(R, p)).linear`` of many placements R (m, 3, 3), p (m, 3), as (3, m):
    Pinocchio 4's log6 and log3 formulas (the rotation renormalised, the Taylor expansions
    near the identity), a block of placements at a time (small arrays: no fresh pages);
    rotations past about 150 deg, where the log is ill-conditioned, are handed to pin.log6
    itself. Agrees with it to 1e-14."""
    R, p = np.asarray(R, dtype=float).reshape(-1, 3, 3), np.asarray(p, dtype=float).reshape(-1, 3)
    out = np.empty((3, len(R)))
    for a in range(0, len(R), LOG_BLOCK):
        out[:, a : a + LOG_BLOCK] = _log6_block(R[a : a + LOG_BLOCK], p[a : a + LOG_BLOCK])
    for i in np.flatnonzero((np.einsum("nii->n", R) - 1.0) / 2.0 < HALF_TURN):
        out[:, i] = pin.log6(pin.SE3(R[i], p[i])).linear
    return out


def _log6_block(R, p) -> np.ndarray:
    """:func:`_log6_linear` of a block of placements (as (3, m))."""
    # by component (r[i, j]: the entry (i, j) of every rotation), contiguous
    r, P = np.ascontiguousarray(R.transpose(1, 2, 0)), np.ascontiguousarray(p.T)

    def unskew(c0, c1, c2):  # of the matrix of columns c0, c1, c2
        return 0.5 * np.stack([c1[2] - c2[1], c2[0] - c0[2], c0[1] - c1[0]])

    a = unskew(r[:, 0], r[:, 1], r[:, 2])
    t2 = a[0] * a[0] + a[1] * a[1] + a[2] * a[2]
    tr = r[0, 0] + r[1, 1] + r[2, 2]
    c0, c1 = (r[:, i] / np.sqrt(r[0, i] ** 2 + r[1, i] ** 2 + r[2, i] ** 2) for i in (0, 1))
    c2 = _cross(c0, c1)
    c0 = _cross(c1, c2)
    trn = c0[0] + c1[1] + c2[2]  # the renormalised rotation's trace
    cos = (trn - 1.0) / 2.0
    with np.errstate(invalid="ignore", divide="ignore"):
        series = np.sqrt(2.0 * (1.0 - cos) + EPS * EPS)
        theta = np.where(trn <= 3.0 - TAYLOR, np.arccos(np.clip(cos, -1.0, 1.0)), series)
        an = unskew(c0, c1, c2)
        n2 = an[0] * an[0] + an[1] * an[1] + an[2] * an[2]
        w = np.where(theta >= TAYLOR, theta / np.sin(theta),
                     1.0 + n2 / 6.0 + n2 * n2 * 3.0 / 40.0) * an  # fmt: skip
        st, ct = np.sin(theta), np.cos(theta)
        near = tr >= 3.0 - TAYLOR
        alpha = np.where(near, 1.0 - t2 / 12.0 - t2 * t2 / 720.0, theta * st / (2.0 * (1.0 - ct)))
        beta = np.where(near, 1.0 / 12.0 + t2 / 720.0,
                        1.0 / (theta * theta) - st / (2.0 * theta * (1.0 - ct)))  # fmt: skip
    wp = w[0] * P[0] + w[1] * P[1] + w[2] * P[2]
    return alpha * P - 0.5 * _cross(w, P) + beta * wp * w


def _acceptance(s, plan, status, message, weight, mu) -> dict:
    """The acceptance criteria, each with its measured value, limit and verdict."""

    def worst(key, fn=np.nanmax, empty=0.0):
        values = s[key][np.isfinite(s[key])]
        return float(fn(values)) if len(values) else empty

    fz = np.concatenate([s["fz_left"], s["fz_right"]])
    fz = fz[np.isfinite(fz)]
    z = s["pelvis_z"]
    rows = [
        # name, value, limit text, passes, unit
        ("free_flyer_torque", worst("tau_base"), "== 0", worst("tau_base") == 0.0, "N, N m"),
        ("min_normal_force", float(fz.min()) if len(fz) else 0.0, ">= -1e-6",
         (fz.min() if len(fz) else 0.0) >= -1e-6, "BW"),
        ("friction_ratio", worst("friction"), f"<= {mu} (feet > 20 % BW)",
         worst("friction") <= mu, ""),
        ("cop_margin", worst("cop_margin", np.nanmin), ">= -1e-4 (feet > 1 % BW)",
         worst("cop_margin", np.nanmin) >= -1e-4, "m inside the sole"),
        ("weld_drift", worst("drift"), "< 1e-3", worst("drift") < 1e-3, "m"),
        ("pelvis_height", float(np.nanmin(z) / z[0]) if len(z) else 0.0, "> 0.8",
         bool(len(z)) and np.nanmin(z) > 0.8 * z[0], "x start"),
        ("trunk_tilt", worst("tilt"), "< 30", worst("tilt") < 30.0, "deg"),
        ("consistency", worst("consistency"), "<= 1e-6", worst("consistency") <= 1e-6,
         "relative (plant vs controller accelerations)"),
        ("joint_ranges", worst("range"), "<= 1e-6", worst("range") <= 1e-6,
         "deg beyond a range (hinges; ball joints by their triplet angles)"),
    ]  # fmt: skip
    checks = {"completed": {"value": status, "limit": "completed", "ok": status == "completed",
                            "unit": message}}  # fmt: skip
    for name, value, limit, ok, unit in rows:
        checks[name] = {"value": value, "limit": limit, "ok": bool(ok), "unit": unit}
    return checks


def _summary(s, plan, gait, weight, status, wall, simulated) -> dict:
    t = s["t"]
    first, last = plan.steps[0], plan.steps[-1]
    window = (t >= first.t_lift) & (t <= last.t_land)
    # speed over the steady steps (the first and last steps are half steps)
    inner = plan.steps[1:-1] or plan.steps
    steady = (t >= inner[0].t_land) & (t <= inner[-1].t_land)
    x = s["com_x"]
    speed = (
        (x[steady][-1] - x[steady][0]) / (t[steady][-1] - t[steady][0])
        if steady.sum() > 2
        else float("nan")
    )
    fz = np.nansum(np.stack([s["fz_left"], s["fz_right"]]), axis=0)
    z = s["com_z"][window]
    err = np.hypot(s["com_x"] - s["com_ref_x"], s["com_y"] - s["com_ref_y"])
    nan = float("nan")
    peak_grf = float(np.nanmax(fz[window])) if window.any() else nan
    lateral = float(np.ptp(s["com_y"][window])) if window.any() else nan
    return {
        "status": status,
        "speed": float(speed),
        "step_length": gait.step_length,
        "cadence": 60.0 / gait.period,
        "double_support": gait.t_double / gait.period,
        "peak_vertical_grf": peak_grf,
        "peak_friction": float(np.nanmax(s["friction"], initial=0.0)),
        "com_vertical_excursion": float(np.ptp(z)) if len(z) else float("nan"),
        "com_lateral_excursion": lateral,
        "com_error_rms": float(np.sqrt(np.nanmean(err**2))),
        "com_error_max": float(np.nanmax(err)),
        "real_time_factor": simulated / wall if wall > 0 else float("inf"),
        "wall_time": wall,
        "simulated": simulated,
    }  # fmt: skip
