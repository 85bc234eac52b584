"""The same scenes in MuJoCo (when it is installed): accuracy against time, side by side.

Four measures, each at several step sizes, for both engines, in the same run:

- free tumble (zero gravity, spinning, joints moving) and free leg swing: relative energy drift
  after T seconds;
- welded stance (both feet welded, gravity, the standing scene's posture controller, pushed at
  the thorax for 0.4 s): the largest weld drift over T seconds;
- passive collapse on welded feet (gravity, no control, 1 s): the largest foot drift;
- the walking segment of the accuracy benchmark (two steps, 4.35 s), driven by the same
  walking controller at 2 ms: the state error against the benchmark's rigid-contact reference
  (DP5 at rtol 1e-12), and the weld drift of the stance feet.

MuJoCo runs the exported model (:mod:`humanoid.export`). Its welds are weld equalities, soft by
design, with two parameter sets: MuJoCo's defaults (solref 0.02 1, solimp 0.9 0.95 0.001) and
the stiffest it allows (solref = 2 dt, its smallest stable time constant, and solimp 0.9999,
its largest impedance). Controllers and pushes are our effects, evaluated on the mapped state
at every MuJoCo step (the walking controller at every 2 ms tick) and applied through
``qfrc_applied``; pushes go through MuJoCo's own ``mj_applyFT`` at the pushed point. The wall
time of a controlled run includes them in both engines. :func:`push_momentum` runs one push on
the free body in both engines and compares the momentum changes with the impulse.

Reported: for each method, the smallest wall time that reaches a target accuracy (``TARGETS``).
"""

from __future__ import annotations

import csv
import time
from pathlib import Path
from typing import Any

import numpy as np
import pinocchio as pin

from ..errors import ModelError
from ..model import child_link
from .common import MALE, load_male

__all__ = ["fall_comparison", "push_momentum", "run_peer_comparison"]

# the target accuracy per scene: relative energy drift (tumble, swing), weld drift [m]
# (stance, collapse), state error against the rigid reference (walk)
TARGETS = {"tumble": 1e-6, "swing": 1e-6, "stance": 1e-6, "collapse": 1e-6, "walk": 1e-3}
STANCE_HZ = 8.0  # the posture controller of the shipped standing scene
PUSH = (80.0, 20.0, 0.0)  # [N] at the thorax, for the first 0.4 s of the stance
# a walk whose stance foot has slid this far [m] is lost (our walk's check allows 1 mm); it
# is stopped there, before the controller's QP starts to struggle with the wrecked state
LOST = 1e-2
# MuJoCo weld parameters: (solref, solimp) for a step dt; None keeps MuJoCo's default solimp
WELDS = {
    "default weld": lambda dt: ("0.02 1", None),
    "stiff weld": lambda dt: (f"{2 * dt:g} 1", "0.9999 0.9999 0.001"),
}


def _free_state(h, scene: str):
    """Initial state of the free scenes: ``tumble`` (spin, joints moving) or ``swing`` (the
    left hip swinging at 3 rad/s, everything else at rest)."""
    rng = np.random.default_rng(0)
    q = h.standing_configuration()
    v = np.zeros(h.nv)
    if scene == "tumble":
        v[3:6] = [0.3, 2.0, 0.5]
        v[6:] = 0.5 * rng.normal(size=h.nv - 6)
    else:
        v[h.model.joints[h.model.getJointId("left_hip")].idx_v] = 3.0
    return q, v


def _mujoco_model(h, xml_extra: str = "", gravity=True, integrator="RK4", dt=1e-3):
    import mujoco

    from ..export import to_mjcf

    xml = to_mjcf(h, timestep=dt, integrator=integrator)
    if not gravity:
        xml = xml.replace('gravity="0 0 -9.8100000000000005"', 'gravity="0 0 0"')
        xml = xml.replace('gravity="0 0 -9.81"', 'gravity="0 0 0"')
    xml = xml.replace("</worldbody>", "</worldbody>\n" + xml_extra)
    return mujoco.MjModel.from_xml_string(xml)


def _energy(m, d):
    import mujoco

    mujoco.mj_energyPos(m, d)
    mujoco.mj_energyVel(m, d)
    return d.energy[0] + d.energy[1]


def _mujoco_free(h, scene, integrator, dt, T):
    import mujoco

    from ..export import mujoco_state

    m = _mujoco_model(h, gravity=False, integrator=integrator, dt=dt)
    m.opt.gravity[:] = 0.0
    d = mujoco.MjData(m)
    q, v = _free_state(h, scene)
    d.qpos[:], d.qvel[:] = mujoco_state(h, m, q, v)
    mujoco.mj_forward(m, d)
    e0 = _energy(m, d)
    start = time.perf_counter()
    for _ in range(int(round(T / dt))):
        mujoco.mj_step(m, d)
    wall = time.perf_counter() - start
    if _unstable(d):
        return wall, float("inf")
    return wall, abs(_energy(m, d) - e0) / abs(e0)


def _ours_free(h, scene, integrator, dt, T):
    from ..scene import Effects, Initial, Scene

    q, v = _free_state(h, scene)
    scene = Scene(
        body=MALE, duration=T, dt=dt, integrator=integrator, record_rate=1.0 / T,
        effects=Effects(gravity=(0.0, 0.0, 0.0)),
        initial=Initial(base_velocity=tuple(v[:6]), joint_velocity=tuple(v[6:])),
    )  # fmt: skip
    return _measured(scene, h, lambda t: abs(t.energy[-1] - t.energy[0]) / abs(t.energy[0]))


def _measured(scene, h, measure):
    """(wall time, measure(trajectory)) of one of our runs; the measure is inf if it failed."""
    from .common import run_scene

    traj, wall = run_scene(scene, h)
    return wall, (float(measure(traj)) if traj.status == "completed" else float("inf"))


def _foot_joints(h) -> list[int]:
    """The joints that carry the soles (left, right)."""
    return [h.model.frames[h.model.getFrameId(sole)].parentJoint for sole in h.feet]


def _welds_xml(h, q, weld: str, dt: float) -> str:
    """MJCF weld equalities (named by side) of both feet at their placement in q."""
    solref, solimp = WELDS[weld](dt)
    imp = f' solimp="{solimp}"' if solimp else ""
    data = h.model.createData()
    pin.forwardKinematics(h.model, data, q)
    lines = ["<equality>"]
    for side, joint in zip(("left", "right"), _foot_joints(h), strict=True):
        body = child_link(h.model, joint)
        rel = " ".join(f"{x:.17g}" for x in _relpose(data.oMi[joint]))
        lines.append(f'  <weld name="{side}" body1="{body}" solref="{solref}"{imp} '
                     f'relpose="{rel}"/>')  # fmt: skip
    lines.append("</equality>")
    return "\n".join(lines)


def _relpose(oMi: pin.SE3) -> np.ndarray:
    """MuJoCo's weld relpose that holds a body at oMi: the world's pose in the body's frame
    (position, quaternion w x y z)."""
    M = oMi.inverse()
    c = pin.Quaternion(M.rotation).coeffs()
    return np.array([*M.translation, c[3], c[0], c[1], c[2]])


def _welded_scene(T, dt, controlled: bool):
    """Both feet welded where they stand: the pushed stance under the posture hold, or (not
    controlled) the passive collapse."""
    from ..scene import Contact, Controller, Effects, PushSpec, Scene

    pushes = (PushSpec("thorax", PUSH, 0.0, 0.4),) if controlled else ()
    return Scene(
        body=MALE, duration=T, dt=dt, record_rate=1.0 / dt,
        effects=Effects(contacts=(Contact("left"), Contact("right")), pushes=pushes),
        controller=Controller("posture", frequency=STANCE_HZ) if controlled else Controller(),
    )  # fmt: skip


def _unstable(d) -> bool:
    """MuJoCo found a bad acceleration (it then resets the state)."""
    import mujoco

    return d.warning[mujoco.mjtWarning.mjWARN_BADQACC].number > 0


def _mujoco_welded(h, scene, integrator, weld):
    """A welded scene in MuJoCo, its controller and pushes applied at every step:
    (wall time, largest foot drift [m]), inf if it diverged."""
    import mujoco

    from ..export import StateMap
    from ..simulation import Simulation

    ours = Simulation(scene, humanoid=h)  # the initial state, controller and pushes
    efforts = [e for e in ours.effects if not e.external]
    efforts += [ours.setup.controller] if ours.setup.controller else []
    pushes = [e for e in ours.effects if e.external]
    model, dt = h.model, scene.dt
    q0 = ours.q0
    data, work = model.createData(), model.createData()
    pin.forwardKinematics(model, data, q0)
    feet = _foot_joints(h)
    anchors = [data.oMi[j].translation.copy() for j in feet]
    m = _mujoco_model(h, _welds_xml(h, q0, weld, dt), integrator=integrator, dt=dt)
    d = mujoco.MjData(m)
    states = StateMap(h, m)
    d.qpos[:], d.qvel[:] = states.to_mujoco(q0, np.zeros(h.nv))
    worst, wall = 0.0, 0.0
    for k in range(int(round(scene.duration / dt))):
        start = time.perf_counter()
        if efforts:
            q, v = states.to_pinocchio(d.qpos, d.qvel)
            tau = sum(f for e in efforts if (f := e.force(model, work, k * dt, q, v)) is not None)
            tau = tau if isinstance(tau, np.ndarray) else np.zeros(model.nv)
            d.qfrc_applied[:] = states.to_mujoco(q, tau)[1]  # forces map like velocities
        _apply_pushes(h, m, d, pushes, k * dt)
        mujoco.mj_step(m, d)
        wall += time.perf_counter() - start  # the drift bookkeeping below is not timed
        pin.forwardKinematics(model, data, states.to_pinocchio(d.qpos, d.qvel)[0])
        worst = max(worst, max(np.linalg.norm(data.oMi[j].translation - a)
                               for j, a in zip(feet, anchors, strict=True)))  # fmt: skip
        if _unstable(d) or not worst < 1.0:
            return wall, float("inf")
    return wall, worst


def _ours_welded(h, scene, integrator, stabilisation):
    """Our run of a welded scene: (wall time, largest weld residual) or inf if it failed."""
    scene = scene.replace(integrator=integrator, stabilisation=stabilisation)
    return _measured(scene, h, lambda t: np.nanmax(t.residual))


def _apply_pushes(h, m, d, pushes, t: float) -> None:
    """Add our pushes active at t to MuJoCo's ``qfrc_applied`` through MuJoCo's own
    ``mj_applyFT`` (the force at the frame's origin, world axes), so that MuJoCo, not our
    Jacobian, turns each into generalised forces."""
    import mujoco

    active = [p for p in pushes if p.active(t)]
    if not active:
        return
    mujoco.mj_kinematics(m, d)  # the body poses of the current state
    mujoco.mj_comPos(m, d)  # and the subtree centres and motion axes mj_applyFT's Jacobian reads
    for p in active:
        body, offset = _mujoco_frame(h, m, p.frame_id)
        point = d.xpos[body] + d.xmat[body].reshape(3, 3) @ offset
        mujoco.mj_applyFT(m, d, p.wrench[:3], p.wrench[3:], point, body, d.qfrc_applied)


def _mujoco_frame(h, m, frame_id: int) -> tuple[int, np.ndarray]:
    """MuJoCo body id that carries a Pinocchio frame, and the frame origin in that body's
    frame (the exported body frame is its last joint's frame)."""
    import mujoco

    frame = h.model.frames[frame_id]
    name = child_link(h.model, frame.parentJoint)
    body = mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_BODY, name)
    if body < 0:
        raise ModelError(f"frame {frame.name} is on a body MuJoCo does not have ({name})")
    return body, np.array(frame.placement.translation)


def push_momentum(h, frame: str = "thorax", force=PUSH, duration: float = 0.3,
                  dt: float = 1e-3) -> dict:  # fmt: skip
    """The same push on the free body in zero gravity in both engines (RK4 at ``dt``): the
    change of linear momentum [N s] and of angular momentum about the centre of mass [N m s]
    of each, against the impulse ``force * duration`` and the angular impulse of r x f
    integrated along each engine's own motion (Simpson's rule on every step)."""
    import mujoco
    from scipy.integrate import simpson

    from ..effects import Push
    from ..export import StateMap
    from ..scene import Effects, Initial, PushSpec, Scene
    from ..simulation import simulate

    T = duration + 0.1
    q0, v0 = _free_state(h, "tumble")
    v0[6:] = 0.0  # a spinning body, joints at rest
    spec = PushSpec(frame, tuple(force), 0.0, duration)
    scene = Scene(body=MALE, duration=T, dt=dt, record_rate=1.0 / dt,
                  effects=Effects(gravity=(0.0, 0.0, 0.0), pushes=(spec,)),
                  initial=Initial(base_velocity=tuple(v0[:6])))  # fmt: skip
    fid = h.model.getFrameId(frame)
    f = np.asarray(force, dtype=float)
    model, data = h.model, h.model.createData()

    def momenta(q, v):
        pin.computeCentroidalMomentum(model, data, q, v)
        pin.framesForwardKinematics(model, data, q)
        arm = np.cross(data.oMf[fid].translation - data.com[0], f)
        return data.hg.linear.copy(), data.hg.angular.copy(), arm

    def summary(qs, vs, t):
        rows = [momenta(q, v) for q, v in zip(qs, vs, strict=True)]
        p, L, arm = (np.array([r[i] for r in rows]) for i in range(3))
        on = t <= duration + 1e-9
        return {"dp": p[-1] - p[0], "dL": L[-1] - L[0],
                "angular_impulse": simpson(arm[on], x=t[on], axis=0)}  # fmt: skip

    traj = simulate(scene, humanoid=h, quiet=True)
    out = {"impulse": f * duration, "humanoid": summary(traj.q, traj.v, traj.t)}
    m = _mujoco_model(h, gravity=False, integrator="RK4", dt=dt)
    m.opt.gravity[:] = 0.0
    d = mujoco.MjData(m)
    states = StateMap(h, m)
    d.qpos[:], d.qvel[:] = states.to_mujoco(q0, v0)
    push = Push(fid, force, 0.0, duration)
    qs, vs = [q0], [v0]
    n = int(round(T / dt))
    for k in range(n):
        d.qfrc_applied[:] = 0.0
        _apply_pushes(h, m, d, [push], k * dt)
        mujoco.mj_step(m, d)
        q, v = states.to_pinocchio(d.qpos, d.qvel)
        qs.append(q)
        vs.append(v)
    out["mujoco"] = summary(qs, vs, np.arange(n + 1) * dt)
    return out


def _mujoco_walk(h, reference, integrator, dt, weld):
    """The benchmark's walking segment in MuJoCo, driven by our walking controller every 2 ms
    (the plant steps dt in between): stance welds switched on and off per the plan, a landing
    foot's weld anchored where it lands. Returns (wall time of the whole loop, state error
    against the rigid-contact reference over the 25 Hz records, largest weld drift [m]); the
    error is inf if the walk failed."""
    import mujoco

    from ..errors import HumanoidError, RunFailed
    from ..export import StateMap
    from ..walking import GaitParameters
    from ..walking.run import prepare
    from .common import CONTROL_DT, RECORD_RATE, WALK_STEPS, state_error

    setup = prepare(h, GaitParameters(steps=WALK_STEPS), dt=CONTROL_DT)
    sim, ctl, plan, model = setup.sim, setup.ctl, setup.plan, h.model
    q, v = setup.q0.copy(), setup.v0  # the controller's view: both feet welded where they stand
    m = _mujoco_model(h, _welds_xml(h, q, weld, dt), integrator=integrator, dt=dt)
    d = mujoco.MjData(m)
    states = StateMap(h, m)
    d.qpos[:], d.qvel[:] = states.to_mujoco(q, v)
    eq = {s: mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_EQUALITY, s) for s in ("left", "right")}
    substeps = int(round(CONTROL_DT / dt))
    every = int(round(1.0 / (RECORD_RATE * CONTROL_DT)))
    qs, vs, drift = [], [], 0.0
    start = time.perf_counter()
    try:
        for k in range(int(round(plan.duration / CONTROL_DT))):
            t = k * CONTROL_DT
            q, v = states.to_pinocchio(d.qpos, d.qvel)
            before = {c.side for c in sim.contacts if c.attached}
            sim.switch_contacts(t, q, v, plan.stance(t))  # MuJoCo's weld stops a landing foot
            stance = {c.side: c.constraints for c in sim.contacts if c.attached}
            welds = {side: constraints[0] for side, constraints in stance.items()}
            for side, i in eq.items():
                if side in welds and side not in before:
                    frame = model.frames[welds[side].frame_id]
                    m.eq_data[i, 3:10] = _relpose(welds[side].anchor * frame.placement.inverse())
                d.eq_active[i] = side in welds
            if k % every == 0:
                qs.append(q)
                vs.append(v)
            sim.kinematics(q, v)
            for w in welds.values():
                drift = max(drift, float(np.linalg.norm(w.residual(model, sim.data)[:3])))
            tau = ctl.update(t, q, v, stance)
            d.qfrc_applied[:] = states.to_mujoco(q, tau)[1]
            for _ in range(substeps):
                mujoco.mj_step(m, d)
            if _unstable(d) or not drift <= LOST or d.qpos[2] < 0.8 * setup.q0[2]:
                raise RunFailed(f"MuJoCo's walk is lost at t = {t:.3f} s")
    except HumanoidError:
        return time.perf_counter() - start, float("inf"), drift
    wall = time.perf_counter() - start
    if len(qs) != len(reference.t):
        return wall, float("inf"), drift
    return wall, state_error(model, reference, qs, vs), drift


def run_peer_comparison(quick: bool = False, out: str | Path = "results/bench",
                        walk=None) -> list[dict]:  # fmt: skip
    """Run the scenes in both engines; print and write peers.csv.

    Args:
        quick: Shorter runs (2 s instead of 10 s) and fewer steps.
        out: Folder for peers.csv.
        walk: ``(reference, rows)`` of the accuracy benchmark's walking segment (its DP5
            reference trajectory and our rows, measured in the same run); None leaves the walk
            out.
    """
    import mujoco

    T, T_collapse = (2.0, 0.5) if quick else (10.0, 1.0)
    warnings: list[str] = []
    previous = mujoco.get_mju_user_warning()
    mujoco.set_mju_user_warning(warnings.append)  # its divergence messages, counted below
    try:
        rows = _sweep(quick, T, T_collapse, walk)
    finally:
        mujoco.set_mju_user_warning(previous)
    if warnings:
        print(f"  MuJoCo warned {len(warnings)} times (its diverged runs, inf above), e.g.: "
              f"{warnings[0].strip()}")  # fmt: skip
    _write_and_summarise(rows, Path(out), T, T_collapse)
    _plot(rows, Path(out) / "peers.png", T, T_collapse)
    _print_push_momentum()
    for name in ("collapse", "drop"):
        _print_fall(fall_comparison(name, duration=2.0 if quick else None))
    print(f"wrote {Path(out) / 'peers.csv'} and peers.png")
    return rows


def _print_push_momentum() -> None:
    """The same push in both engines: momentum changes beside the impulse."""

    r = push_momentum(load_male())
    impulse = r["impulse"]
    print(f"\npush {PUSH} N at the thorax for 0.3 s, free body in zero gravity, RK4 at 1 ms:")
    print(f"  impulse                       {np.array2string(impulse, precision=6)} N s")
    for engine in ("humanoid", "mujoco"):
        x = r[engine]
        dp = np.abs(x["dp"] - impulse).max() / np.linalg.norm(impulse)
        dl = np.abs(x["dL"] - x["angular_impulse"]).max() / np.linalg.norm(x["angular_impulse"])
        print(f"  {engine:<9} delta p - impulse: {dp:.1e}   delta L - its angular impulse: "
              f"{dl:.1e} (relative)")  # fmt: skip
    gap = np.abs(r["humanoid"]["dL"] - r["mujoco"]["dL"]).max() / np.linalg.norm(r["mujoco"]["dL"])
    print(
        f"  delta L, the two engines apart: {gap:.1e} (MuJoCo holds the generalised force of "
        "a moving point constant over each step)"
    )


REST = 1e-2  # [J] kinetic energy below which (for good) a fallen body is at rest


def fall_comparison(name: str = "collapse", duration: float | None = None) -> dict:
    """A shipped fall scene (``collapse`` or ``drop``) in both engines, side by side.

    Ours: the scene as shipped (rigid ground contact for every body, joint ranges as
    constraints, semi-implicit Euler). MuJoCo: the same body exported with its hinge triplets
    (Euler mode: MuJoCo's ball joints cannot take the triplets' angle ranges), hinge limits,
    the scene's joint damping and friction on a floor plane, elliptic cones, its default soft
    contacts and its default (semi-implicit Euler) integrator at the same step, from the same
    initial state. Returns per engine: the time to rest (kinetic energy below ``REST`` from
    then on), the final pelvis height, its forward axis's vertical component (+1: lying on
    its back), the final CoM, the deepest penetration, and the wall time per step measured
    in the same run; and the RMS difference of the final joint angles [deg].
    """
    from ..scene import Scene
    from ..simulation import Simulation

    scene = Scene.load(name).replace(body=MALE)
    if duration is not None:
        scene = scene.replace(duration=duration)
    dt, n = scene.dt, int(round(scene.duration / scene.dt))
    every = max(1, int(round(1.0 / (scene.record_rate * dt))))
    sim = Simulation(scene)
    traj = sim.run(quiet=True)
    h, he = sim.h, load_male("euler")
    qs, vs, wall, depth = mujoco_fall(scene, h, he, sim.q0, sim.v0, dt, every)
    t_mj = np.arange(len(qs)) * dt * every
    out: dict[str, Any] = {"scene": name, "dt": dt, "duration": scene.duration, "steps": n,
           "humanoid": _fall_summary(h, traj.q, traj.v, traj.t),
           "mujoco": _fall_summary(he, np.array(qs), np.array(vs), t_mj)}  # fmt: skip
    out["humanoid"] |= {"step_time": traj.metadata["wall_time"] / traj.metadata["steps"],
                        "penetration": traj.metadata["max_penetration"]}  # fmt: skip
    out["mujoco"] |= {"step_time": wall / n, "penetration": depth}
    assert h.fusion is not None  # the toolkit's body, its balls as quaternions
    final = h.fusion.to_euler(traj.q[-1])[0]  # our final posture as hinge angles
    diff = final[7:] - qs[-1][7:]  # the hinge angles (after the free flyer's 7)
    out["joint_rms_deg"] = float(np.degrees(np.sqrt(np.mean(np.angle(np.exp(1j * diff)) ** 2))))
    return out


# MuJoCo's stiffest stable contacts for a step dt, as the stiff welds: its smallest time
# constant (solref 2 dt, critically damped) and an impedance of 0.9999 at every depth
STIFF_CONTACT_SOLIMP = (0.9999, 0.9999, 0.001, 0.5, 2.0)


def _fall_model(scene, he, dt: float, integrator: str = "Euler", stiff: bool = False):
    """The MuJoCo model of a fall scene: the Euler-mode body with hinge limits, the scene's
    joint damping, and a floor with the scene's friction; ``stiff``: every geometry's
    contacts at solref (2 dt, 1) and solimp :data:`STIFF_CONTACT_SOLIMP` (MuJoCo's defaults
    otherwise: solref 0.02 1, solimp 0.9 0.95 0.001)."""
    import mujoco

    from ..export import to_mjcf

    xml = to_mjcf(he, timestep=dt, integrator=integrator, ground=scene.effects.ground.mu,
                  limits=True, damping=scene.effects.damping)  # fmt: skip
    m = mujoco.MjModel.from_xml_string(xml)
    if stiff:
        m.geom_solref[:] = (2.0 * dt, 1.0)
        m.geom_solimp[:] = STIFF_CONTACT_SOLIMP
    return m


def mujoco_fall(scene, h, he, q0, v0, dt: float, every: int, integrator: str = "Euler",
                stiff: bool = False):  # fmt: skip
    """A fall scene in MuJoCo from our initial state (q0, v0) of ``h`` (quaternion mode), on
    the Euler-mode body ``he``: Euler-mode states (q, v) every ``every`` steps (the first at
    t = 0), the wall time of the steps alone, and the deepest penetration [m]. ``stiff``:
    MuJoCo's stiffest contacts (:func:`_fall_model`)."""
    import mujoco

    from ..export import StateMap

    m = _fall_model(scene, he, dt, integrator, stiff)
    d = mujoco.MjData(m)
    states = StateMap(he, m)
    qe0, ve0 = h.fusion.to_euler(q0, v0)
    d.qpos[:], d.qvel[:] = states.to_mujoco(qe0, ve0)
    qs, vs, wall, depth = [qe0], [ve0], 0.0, 0.0
    for k in range(int(round(scene.duration / dt))):
        start = time.perf_counter()
        mujoco.mj_step(m, d)
        wall += time.perf_counter() - start
        if d.ncon:
            depth = max(depth, -float(d.contact.dist[: d.ncon].min()))
        if (k + 1) % every == 0:
            q, v = states.to_pinocchio(d.qpos, d.qvel)
            qs.append(q)
            vs.append(v)
    return qs, vs, wall, depth


def _fall_summary(h, qs, vs, t) -> dict:
    model, data = h.model, h.model.createData()
    ke = np.array(
        [pin.computeKineticEnergy(model, data, q, v) for q, v in zip(qs, vs, strict=True)]
    )
    moving = np.flatnonzero(ke >= REST)
    rest = float(t[moving[-1] + 1]) if len(moving) and moving[-1] + 1 < len(t) else (
        float("nan") if len(moving) else 0.0)  # fmt: skip
    q = qs[-1]
    R = pin.Quaternion(q[3:7]).toRotationMatrix()
    return {
        "time_to_rest": rest,
        "pelvis_height": float(q[2]),
        "pelvis_forward_z": float(R[2, 0]),
        "com": pin.centerOfMass(model, data, q).copy(),
        "final_kinetic_energy": float(ke[-1]),
    }


def _print_fall(r: dict) -> None:
    """The fall comparison as a small table."""
    print(f"\n{r['scene']}: {r['duration']:g} s at dt = {r['dt'] * 1e3:g} ms, same initial state")
    print(f"  {'':<28} {'humanoid':>12} {'mujoco':>12}")
    rows = (("time to rest [s]", "time_to_rest", "{:.3f}"),
            ("pelvis height [m]", "pelvis_height", "{:.3f}"),
            ("pelvis forward axis, z", "pelvis_forward_z", "{:+.2f}"),
            ("final kinetic energy [J]", "final_kinetic_energy", "{:.1e}"),
            ("deepest penetration [mm]", "penetration", "{:.3f}"),
            ("wall time per step [us]", "step_time", "{:.0f}"))  # fmt: skip
    for label, key, fmt in rows:
        scale = 1e3 if key == "penetration" else 1e6 if key == "step_time" else 1.0
        a, b = (fmt.format(r[e][key] * scale) for e in ("humanoid", "mujoco"))
        print(f"  {label:<28} {a:>12} {b:>12}")
    for e in ("humanoid", "mujoco"):
        print(f"  final CoM, {e:<17} {np.array2string(r[e]['com'], precision=3)} m")
    ratio = r["humanoid"]["step_time"] / r["mujoco"]["step_time"]
    print(f"  final joint angles apart (RMS): {r['joint_rms_deg']:.1f} deg; step time ratio "
          f"ours / mj_step: {ratio:.1f}")  # fmt: skip


def _sweep(quick, T, T_collapse, walk) -> list[dict]:
    from ..scene import Stabilisation

    h = load_male()
    dts = (4e-3, 2e-3, 1e-3) if quick else (8e-3, 4e-3, 2e-3, 1e-3, 5e-4)
    # the free scenes also at 5 and 3 ms: where each engine's RK4 crosses its target
    free_dts = dts if quick else (8e-3, 5e-3, 4e-3, 3e-3, 2e-3, 1e-3, 5e-4)
    mj_integrators = ("Euler", "implicitfast", "RK4")
    rows = []

    def add(scene, engine, method, dt, wall, error, drift=float("nan")):
        rows.append({"scene": scene, "engine": engine, "method": method, "dt": dt,
                     "wall": wall, "error": error, "drift": drift})  # fmt: skip
        print(f"  {scene:<8} {engine:<9} {method:<34} dt={dt:<7g} {wall:8.3f} s  {error:.2e}",
              flush=True)  # fmt: skip

    for dt in free_dts:
        for integrator in mj_integrators:
            for scene in ("tumble", "swing"):
                add(scene, "mujoco", integrator, dt, *_mujoco_free(h, scene, integrator, dt, T))
        for integrator in ("semi_implicit_euler", "rk4"):
            for scene in ("tumble", "swing"):
                add(scene, "humanoid", integrator, dt, *_ours_free(h, scene, integrator, dt, T))
    stabilisations = (
        ("semi-implicit, baumgarte 20 dt", "semi_implicit_euler", Stabilisation(baumgarte=20.0)),
        ("semi-implicit, projection", "semi_implicit_euler", Stabilisation(projection=True)),
        ("rk4, baumgarte 20 dt", "rk4", Stabilisation(baumgarte=20.0)),
    )
    for name, duration, controlled in (("stance", T, True), ("collapse", T_collapse, False)):
        for dt in dts:
            scene = _welded_scene(duration, dt, controlled)
            for integrator in mj_integrators:
                for weld in WELDS:
                    wall, drift = _mujoco_welded(h, scene, integrator, weld)
                    add(name, "mujoco", f"{integrator}, {weld}", dt, wall, drift, drift)
            for label, integrator, stab in stabilisations:
                wall, drift = _ours_welded(h, scene, integrator, stab)
                add(name, "humanoid", label, dt, wall, drift, drift)
    if walk is not None:
        reference, ours = walk
        walk_dts = (2e-3, 1e-3) if quick else (2e-3, 1e-3, 5e-4, 2.5e-4)
        for dt in walk_dts:
            for integrator in mj_integrators:
                for weld in WELDS:
                    add("walk", "mujoco", f"{integrator}, {weld}", dt,
                        *_mujoco_walk(h, reference, integrator, dt, weld))  # fmt: skip
        for r in ours:
            if r.setting.startswith("dt="):
                add("walk", "humanoid", r.method, float(r.setting[3:]), r.wall, r.error,
                    r.constraint_drift)  # fmt: skip
    return rows


def _units(T, T_collapse) -> dict:
    return {"tumble": f"relative energy drift over {T:g} s",
            "swing": f"relative energy drift over {T:g} s",
            "stance": f"weld drift over {T:g} s [m]",
            "collapse": f"weld drift over {T_collapse:g} s [m]",
            "walk": "state error against the rigid reference"}  # fmt: skip


def _plot(rows, path: Path, T, T_collapse) -> None:
    """Accuracy against wall time, one panel per scene, one curve per engine and method
    (MuJoCo dashed); failed runs are left out, the target is a dotted line."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    units = _units(T, T_collapse)
    scenes = [s for s in TARGETS if any(r["scene"] == s for r in rows)]
    fig, axes = plt.subplots(2, 3, figsize=(15, 8.5), constrained_layout=True)
    for ax, scene in zip(axes.flat, scenes, strict=False):
        for engine, method in sorted({(r["engine"], r["method"]) for r in rows
                                      if r["scene"] == scene}):  # fmt: skip
            pts = sorted((r["wall"], r["error"]) for r in rows
                         if (r["scene"], r["engine"], r["method"]) == (scene, engine, method)
                         and np.isfinite(r["error"]) and r["error"] > 0)  # fmt: skip
            if pts:
                w, e = zip(*pts, strict=True)
                style = "s--" if engine == "mujoco" else "o-"
                ax.loglog(w, e, style, ms=4, label=f"{engine}: {method}")
        ax.axhline(TARGETS[scene], color="k", ls=":", lw=1)
        ax.set(xlabel="wall time [s]", ylabel=units[scene], title=scene)
        ax.grid(alpha=0.3, which="both")
        ax.legend(fontsize=6)
    for ax in axes.flat[len(scenes) :]:
        ax.axis("off")
    fig.savefig(path, dpi=80)
    plt.close(fig)


def _write_and_summarise(rows, folder: Path, T, T_collapse) -> None:
    folder.mkdir(parents=True, exist_ok=True)
    with open(folder / "peers.csv", "w", newline="") as fh:
        w = csv.DictWriter(fh, fieldnames=list(rows[0]))
        w.writeheader()
        w.writerows(rows)
    units = _units(T, T_collapse)
    print("\ntime to reach the target accuracy (fastest run that reaches it):")
    for scene, target in TARGETS.items():
        methods = sorted({(r["engine"], r["method"]) for r in rows if r["scene"] == scene})
        if not methods:
            continue
        print(f"  {scene} (target {target:g} {units[scene]}):")
        for key in methods:
            runs = [r for r in rows if r["scene"] == scene and (r["engine"], r["method"]) == key]
            ok = [r for r in runs if r["error"] <= target]
            best = min(ok, key=lambda r: r["wall"]) if ok else None
            closest = min(r["error"] for r in runs)
            text = (f"{best['wall']:.3f} s (dt {best['dt']:g})" if best
                    else f"not reached (best {closest:.1e})")  # fmt: skip
            print(f"    {key[0]:<9} {key[1]:<34} {text}")
