"""The same scenes in MuJoCo (when it is installed): accuracy against time, side by side.

Two measures, each at several step sizes, for both engines, in the same run:

- free tumble (zero gravity, spinning, joints moving) and free leg swing: relative energy drift
  after T seconds;
- welded stance (both feet welded, gravity, the standing scene's posture controller): the
  largest weld drift over T seconds, for the project's stabilisations. The MuJoCo side of this
  scene is not in yet (see the README): its soft welds drift by centimetres within a second
  without control, and the posture controller's gains, computed for rigid welds, make them
  explode; a fair comparison needs a controller valid for both contact models.

- passive collapse on welded feet (gravity, no control, 1 s; the same scene in both engines):
  the largest foot drift from the weld anchors, for MuJoCo's weld equalities (default solref
  and solref = 2 dt) and for our rigid welds (Baumgarte, projection).

MuJoCo runs the exported model (:mod:`humanoid.export`). Reported: for each method, the
smallest wall time that reaches a target accuracy (energy drift 1e-6 over the tumble; weld
drift 1e-6 m over the stance and the collapse).
"""

from __future__ import annotations

import csv
import time
from pathlib import Path

import numpy as np

__all__ = ["run_peer_comparison"]

ROOT = Path(__file__).resolve().parent.parent
MALE = str(ROOT / "models" / "adult_male.urdf")
TARGETS = {"tumble": 1e-6, "swing": 1e-6, "stance": 1e-6, "collapse": 1e-6}
STANCE_HZ = 8.0  # the posture controller of the shipped standing scene


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

    from .export import to_mjcf

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

    from .export import mujoco_state

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
    if d.warning[mujoco.mjtWarning.mjWARN_BADQACC].number > 0:
        return wall, float("inf")  # MuJoCo diverged (and reset the state)
    return wall, abs(_energy(m, d) - e0) / abs(e0)


def _ours_free(h, scene, integrator, dt, T):
    from .scene import Effects, Initial, Scene

    q, v = _free_state(h, scene)
    scene = Scene(
        body=MALE, duration=T, dt=dt, integrator=integrator, record_rate=1.0 / T,
        effects=Effects(gravity=(0.0, 0.0, 0.0)),
        initial=Initial(base_velocity=tuple(v[:6]), joint_velocity=tuple(v[6:])),
    )  # fmt: skip
    return _measured(scene, h, lambda t: abs(t.energy[-1] - t.energy[0]) / abs(t.energy[0]))


def _measured(scene, h, measure):
    """(wall time, measure(trajectory)) of one of our runs; the measure is inf if it failed."""
    from .accuracy import _run

    traj, wall = _run(scene, h)
    return wall, (float(measure(traj)) if traj.status == "completed" else float("inf"))


def _welds_xml(h, q, solref: str) -> tuple[str, list[int], list[np.ndarray]]:
    """MJCF weld equalities of both feet at their placement in q (and their joints, anchors)."""
    import pinocchio as pin

    data = h.model.createData()
    pin.forwardKinematics(h.model, data, q)
    lines, joints, anchors = ["<equality>"], [], []
    for side, sole in zip(("left", "right"), h.feet, strict=True):
        joint = h.model.frames[h.model.getFrameId(sole)].parentJoint
        body = next(f.name for f in h.model.frames
                    if f.parentJoint == joint and f.type == pin.FrameType.BODY)  # fmt: skip
        M = data.oMi[joint].inverse()  # the world's pose in the foot body's frame
        c = pin.Quaternion(M.rotation).coeffs()
        rel = " ".join(f"{x:.17g}" for x in (*M.translation, c[3], c[0], c[1], c[2]))
        lines.append(f'  <weld name="{side}" body1="{body}" solref="{solref}" relpose="{rel}"/>')
        joints.append(joint)
        anchors.append(data.oMi[joint].translation.copy())
    lines.append("</equality>")
    return "\n".join(lines), joints, anchors


def _mujoco_collapse(h, integrator, dt, T, solref):
    """The passive collapse on welded feet in MuJoCo: the largest foot drift [m]."""
    import mujoco
    import pinocchio as pin

    from .export import mujoco_state, pinocchio_state

    q0 = h.standing_configuration()
    welds, joints, anchors = _welds_xml(h, q0, solref)
    m = _mujoco_model(h, welds, integrator=integrator, dt=dt)
    d = mujoco.MjData(m)
    d.qpos[:], d.qvel[:] = mujoco_state(h, m, q0, np.zeros(h.nv))
    data = h.model.createData()
    worst, wall = 0.0, 0.0
    for _ in range(int(round(T / dt))):
        start = time.perf_counter()
        mujoco.mj_step(m, d)
        wall += time.perf_counter() - start  # the drift bookkeeping below is not timed
        pin.forwardKinematics(h.model, data, pinocchio_state(h, m, d.qpos, d.qvel)[0])
        worst = max(worst, max(np.linalg.norm(data.oMi[j].translation - a)
                               for j, a in zip(joints, anchors, strict=True)))  # fmt: skip
    if d.warning[mujoco.mjtWarning.mjWARN_BADQACC].number > 0:
        return wall, float("inf")
    return wall, worst


def _ours_welded(h, T, dt, integrator, stabilisation, controller=None, record_rate=None):
    """Our run on both feet welded: (wall time, largest weld residual) or inf if it failed."""
    from .scene import Contact, Controller, Effects, Scene

    scene = Scene(
        body=MALE, duration=T, dt=dt, integrator=integrator, record_rate=record_rate or 1.0 / dt,
        effects=Effects(contacts=(Contact("left"), Contact("right"))),
        controller=controller or Controller(), stabilisation=stabilisation,
    )  # fmt: skip
    return _measured(scene, h, lambda t: np.nanmax(t.residual))


def run_peer_comparison(quick: bool = False, out: str | Path = "results/bench") -> list[dict]:
    """Run both scenes in both engines; print and write peers.csv."""
    from .model import load
    from .scene import Controller, Stabilisation

    h = load(MALE)
    T = 2.0 if quick else 10.0
    dts = (4e-3, 2e-3, 1e-3) if quick else (8e-3, 4e-3, 2e-3, 1e-3, 5e-4)
    rows = []

    def add(scene, engine, method, dt, result):
        wall, error = result
        rows.append({"scene": scene, "engine": engine, "method": method, "dt": dt,
                     "wall": wall, "error": error})  # fmt: skip
        print(f"  {scene:<7} {engine:<9} {method:<26} dt={dt:<7g} {wall:8.3f} s  {error:.2e}",
              flush=True)  # fmt: skip

    for dt in dts:
        for integrator in ("Euler", "implicitfast", "RK4"):
            for scene in ("tumble", "swing"):
                add(scene, "mujoco", integrator, dt, _mujoco_free(h, scene, integrator, dt, T))
        for integrator in ("semi_implicit_euler", "rk4"):
            for scene in ("tumble", "swing"):
                add(scene, "humanoid", integrator, dt, _ours_free(h, scene, integrator, dt, T))
    for dt in dts:
        for label, stab in (("baumgarte 20 dt", Stabilisation(baumgarte=20.0)),
                            ("projection", Stabilisation(projection=True)),
                            ("baumgarte, pin backend",
                             Stabilisation(baumgarte=20.0, backend="pinocchio"))):  # fmt: skip
            add("stance", "humanoid", f"semi-implicit, {label}", dt,
                _ours_welded(h, T, dt, "semi_implicit_euler", stab,
                             Controller("posture", frequency=STANCE_HZ), 50.0))  # fmt: skip
    T_collapse = 0.5 if quick else 1.0
    for dt in dts:
        for integrator in ("Euler", "implicitfast"):
            for solref in ("0.02 1", f"{2 * dt:g} 1"):
                add("collapse", "mujoco", f"{integrator}, weld solref {solref.split()[0]}", dt,
                    _mujoco_collapse(h, integrator, dt, T_collapse, solref))  # fmt: skip
        for label, stab in (("baumgarte 20 dt", Stabilisation(baumgarte=20.0)),
                            ("projection", Stabilisation(projection=True))):  # fmt: skip
            add("collapse", "humanoid", f"semi-implicit, {label}", dt,
                _ours_welded(h, T_collapse, dt, "semi_implicit_euler", stab))  # fmt: skip
    folder = Path(out)
    folder.mkdir(parents=True, exist_ok=True)
    with open(folder / "peers.csv", "w", newline="") as fh:
        w = csv.DictWriter(fh, fieldnames=list(rows[0]))
        w.writeheader()
        w.writerows(rows)
    print("\ntime to reach the target accuracy (fastest run that reaches it):")
    for scene, target in TARGETS.items():
        unit = "relative energy drift" if scene in ("tumble", "swing") else "m weld drift"
        span = f"{T_collapse:g} s" if scene == "collapse" else f"{T:g} s"
        unit += f" over {span}"
        print(f"  {scene} (target {target:g} {unit}):")
        for key in sorted({(r["engine"], r["method"]) for r in rows if r["scene"] == scene}):
            ok = [r for r in rows if r["scene"] == scene and (r["engine"], r["method"]) == key
                  and r["error"] <= target]  # fmt: skip
            best = min(ok, key=lambda r: r["wall"]) if ok else None
            text = f"{best['wall']:.3f} s (dt {best['dt']:g})" if best else "not reached"
            print(f"    {key[0]:<9} {key[1]:<28} {text}")
    print(f"wrote {folder / 'peers.csv'}")
    return rows
