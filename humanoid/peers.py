"""The same scenes in MuJoCo (when it is installed): accuracy against time, side by side.

Two measures, each at several step sizes, for both engines, in the same run:

- free tumble (zero gravity, spinning, joints moving): relative energy drift after T seconds;
- welded stance (both feet welded, gravity, the standing scene's posture controller): the
  largest weld drift over T seconds, for the project's stabilisations. The MuJoCo side of this
  scene is not in yet (see the README): its soft welds drift by centimetres within a second
  without control, and the posture controller's gains, computed for rigid welds, make them
  explode; a fair comparison needs a controller valid for both contact models.

MuJoCo runs the exported model (:mod:`humanoid.export`). Reported: for each method, the
smallest wall time that reaches a target accuracy (energy drift 1e-6 over the tumble; weld
drift 1e-6 m over the stance).
"""

from __future__ import annotations

import csv
import time
from pathlib import Path

import numpy as np

__all__ = ["run_peer_comparison"]

ROOT = Path(__file__).resolve().parent.parent
MALE = str(ROOT / "models" / "adult_male.urdf")
TARGETS = {"tumble": 1e-6, "stance": 1e-6}
STANCE_HZ = 8.0  # the posture controller of the shipped standing scene


def _tumble_state(h):
    rng = np.random.default_rng(0)
    q = h.standing_configuration()
    v = np.zeros(h.nv)
    v[3:6] = [0.3, 2.0, 0.5]
    v[6:] = 0.5 * rng.normal(size=h.nv - 6)
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


def _mujoco_tumble(h, integrator, dt, T):
    import mujoco

    from .export import mujoco_state

    m = _mujoco_model(h, gravity=False, integrator=integrator, dt=dt)
    m.opt.gravity[:] = 0.0
    d = mujoco.MjData(m)
    q, v = _tumble_state(h)
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


def _ours_tumble(h, integrator, dt, T):
    from .scene import Effects, Initial, Scene
    from .simulate import Simulation

    q, v = _tumble_state(h)
    scene = Scene(
        body=MALE, duration=T, dt=dt, integrator=integrator, record_rate=1.0 / T,
        effects=Effects(gravity=(0.0, 0.0, 0.0)),
        initial=Initial(base_velocity=tuple(v[:6]), joint_velocity=tuple(v[6:])),
    )  # fmt: skip
    start = time.perf_counter()
    traj = Simulation(scene, humanoid=h).run(quiet=True)
    wall = time.perf_counter() - start
    if traj.status != "completed":
        return wall, float("inf")
    return wall, abs(traj.energy[-1] - traj.energy[0]) / abs(traj.energy[0])


def _ours_stance(h, integrator, dt, T, stabilisation):
    from .scene import Contact, Controller, Effects, Scene
    from .simulate import Simulation

    scene = Scene(
        body=MALE, duration=T, dt=dt, integrator=integrator, record_rate=50.0,
        effects=Effects(contacts=(Contact("left"), Contact("right"))),
        controller=Controller("posture", frequency=STANCE_HZ), stabilisation=stabilisation,
    )  # fmt: skip
    start = time.perf_counter()
    traj = Simulation(scene, humanoid=h).run(quiet=True)
    wall = time.perf_counter() - start
    if traj.status != "completed":
        return wall, float("inf")
    return wall, float(np.nanmax(traj.residual))


def run_peer_comparison(quick: bool = False, out: str | Path = "results/bench") -> list[dict]:
    """Run both scenes in both engines; print and write peers.csv."""
    from .model import load
    from .scene import Stabilisation

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
            add("tumble", "mujoco", integrator, dt, _mujoco_tumble(h, integrator, dt, T))
        for integrator in ("semi_implicit_euler", "rk4"):
            add("tumble", "humanoid", integrator, dt, _ours_tumble(h, integrator, dt, T))
    for dt in dts:
        for label, stab in (("baumgarte 20 dt", Stabilisation(baumgarte=20.0)),
                            ("projection", Stabilisation(projection=True)),
                            ("baumgarte, pin backend",
                             Stabilisation(baumgarte=20.0, backend="pinocchio"))):  # fmt: skip
            add("stance", "humanoid", f"semi-implicit, {label}", dt,
                _ours_stance(h, "semi_implicit_euler", dt, T, stab))  # fmt: skip
    folder = Path(out)
    folder.mkdir(parents=True, exist_ok=True)
    with open(folder / "peers.csv", "w", newline="") as fh:
        w = csv.DictWriter(fh, fieldnames=list(rows[0]))
        w.writeheader()
        w.writerows(rows)
    print(f"\ntime to reach the target accuracy over {T:g} s (fastest run that reaches it):")
    for scene, target in TARGETS.items():
        unit = "relative energy drift" if scene == "tumble" else "m weld drift"
        print(f"  {scene} (target {target:g} {unit}):")
        for key in sorted({(r["engine"], r["method"]) for r in rows if r["scene"] == scene}):
            ok = [r for r in rows if r["scene"] == scene and (r["engine"], r["method"]) == key
                  and r["error"] <= target]  # fmt: skip
            best = min(ok, key=lambda r: r["wall"]) if ok else None
            text = f"{best['wall']:.3f} s (dt {best['dt']:g})" if best else "not reached"
            print(f"    {key[0]:<9} {key[1]:<28} {text}")
    print(f"wrote {folder / 'peers.csv'}")
    return rows
