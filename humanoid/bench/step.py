"""``humanoid bench step``: the cost of one simulation step against Pinocchio doing the same.

For every shipped scene, one step of the project's simulator (semi-implicit Euler: one dynamics
evaluation and one ``integrate``) is timed against the equivalent Pinocchio calls measured in
the same run, interleaved: ``pin.aba`` + ``pin.integrate`` for contact-free scenes,
``pin.constraintDynamics`` + ``pin.integrate`` for scenes with contacts (its rigid constraint
models built here with Pinocchio's API alone). Three variants of ours: the dynamics only (no
effects, the like-for-like comparison) with the default native backend, the same through the
NumPy reference KKT solve, and the scene as shipped (with its effects and controller, native).
Each figure is the best of several rounds, the variants' rounds interleaved (the machine is
shared and noisy: a slow spell slows them all); ratios are what to read.

Scenes with ground contact (one frictional contact solve per step, whose size changes as the
body moves) are timed apart, over their first seconds, against MuJoCo's ``mj_step`` on the same
fall (see :func:`_ground_steps`).
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pinocchio as pin

from ..data import SCENES
from ..errors import BenchError
from .common import MALE, best_times, load_male, pinocchio_contacts, write_rows

__all__ = ["STEP_COLUMNS", "run_step_benchmark"]

# step.csv's columns (seconds per step), in the order of the README's table
STEP_COLUMNS = ["scene", "contacts", "pinocchio", "native", "reference", "as shipped"]


def _pinocchio_step(sim, q, v, dt):
    """The equivalent Pinocchio work: dynamics + integrate, plain calls. The contacts are
    Pinocchio's own rigid constraint models, built from the scene's contact frames here (a 6D
    weld of the sole where it stands, or 3D points at the sole's corners)."""
    model = sim.model
    data = model.createData()
    tau = np.zeros(model.nv)
    if not sim.active_constraints():

        def step():
            a = pin.aba(model, data, q, v, tau, pin.Convention.WORLD)
            pin.integrate(model, q, (v + dt * a) * dt)

        return step
    pin.framesForwardKinematics(model, data, q)
    welded = [c.sole for c in sim.contacts if c.spec.kind == "weld"]
    pinned = [p for c in sim.contacts if c.spec.kind != "weld" for p in c.points]
    cms, cds = pinocchio_contacts(model, data, welded, pinned)
    pin.initConstraintDynamics(model, data, cms, cds)
    redundant = len(cms) > len(sim.contacts)
    prox = pin.ProximalSettings(1e-12, 1e-12, 1e-2 if redundant else 0.0, 50 if redundant else 1)

    def step():
        a = pin.constraintDynamics(model, data, q, v, tau, cms, cds, prox)
        pin.integrate(model, q, (v + dt * a) * dt)

    return step


def run_step_benchmark(quick: bool = False, out: str | Path = "results/bench") -> int:
    """Time one step per shipped scene; print a table and write ``step.csv``."""
    from ..scene import Effects, Scene, Stabilisation
    from ..simulation import Simulation

    n, rounds = (200, 3) if quick else (1000, 7)
    rows, ground = [], []
    for path in sorted(SCENES.glob("*.toml")):
        scene = Scene.load(path).replace(integrator="semi_implicit_euler", body=MALE)
        if scene.effects.ground is not None:
            ground.append(path)
            continue
        bare = scene.replace(
            effects=Effects(gravity=scene.effects.gravity, contacts=scene.effects.contacts),
            controller=type(scene.controller)(),
        )
        reference = bare.replace(
            stabilisation=Stabilisation(baumgarte=bare.stabilisation.baumgarte, backend="reference")
        )
        variants = {}
        for label, sc in (("as shipped", scene), ("native", bare), ("reference", reference)):
            sim = Simulation(sc)
            q, v = sim.q0.copy(), sim.v0.copy()
            sim.update_contacts(0.0, q, v)
            variants[label] = (sim, q, v)
        sim0, q0, v0 = variants["native"]
        fns = {"pinocchio": _pinocchio_step(sim0, q0, v0, scene.dt)}
        for label, (sim, q, v) in variants.items():
            fns[label] = lambda s=sim, q=q, v=v, dt=scene.dt: s.step(0.0, q, v, dt)
        times = best_times(fns, n, rounds)
        contacts = "+".join(f"{c.foot}:{c.kind}" for c in scene.effects.contacts) or "none"
        rows.append({"scene": scene.name, "contacts": contacts} | times)

    header = STEP_COLUMNS
    print(
        f"{'scene':<10} {'contacts':<24} {'pinocchio':>10} {'native':>10} {'ratio':>6} "
        f"{'reference':>10} {'ratio':>6} {'as shipped':>11} {'ratio':>6}   [us per step]"
    )
    for r in rows:
        p = r["pinocchio"]
        print(
            f"{r['scene']:<10} {r['contacts']:<24} {p * 1e6:>10.1f} {r['native'] * 1e6:>10.1f} "
            f"{r['native'] / p:>6.2f} {r['reference'] * 1e6:>10.1f} "
            f"{r['reference'] / p:>6.2f} {r['as shipped'] * 1e6:>11.1f} "
            f"{r['as shipped'] / p:>6.2f}"
        )
    if not rows and not ground:
        raise BenchError(f"no scenes to time: none found in {SCENES}")
    folder = Path(out)
    folder.mkdir(parents=True, exist_ok=True)
    write_rows(folder / "step.csv", rows, header)
    print(f"wrote {folder / 'step.csv'}")
    ground_rows = _ground_steps(ground, 0.3 if quick else 2.0, folder)
    report = folder / "speed.md"
    report.write_text(_markdown(rows, ground_rows, n, rounds, 0.3 if quick else 2.0))
    print(f"wrote {report}")
    return 0


def _markdown(rows, ground_rows, n, rounds, duration) -> str:
    """The two speed tables as Markdown, with where and when they were measured (the README
    carries this file's text: ``make bench``)."""
    from ..provenance import machine

    lines = [
        f"Measured by `humanoid bench step` on {machine()}. Microseconds per step, best of "
        f"{rounds} rounds of {n} steps; ratio = ours / Pinocchio in the same run.",
        "",
        "| scene | contacts | Pinocchio | native | ratio | reference KKT | ratio "
        "| as shipped | ratio |",
        "|---|---|---|---|---|---|---|---|---|",
    ]
    for r in rows:
        p = r["pinocchio"]
        cells = [r["scene"], r["contacts"], f"{p * 1e6:.1f}"]
        for key in STEP_COLUMNS[3:]:
            cells += [f"{r[key] * 1e6:.1f}", f"{r[key] / p:.2f}"]
        lines.append("| " + " | ".join(cells) + " |")
    if ground_rows:
        lines += [
            "",
            f"Ground contact, the mean over the first {duration:g} s of each scene against "
            "MuJoCo's `mj_step` on the same fall in the same run:",
            "",
            "| scene | ours [us per step] | `mj_step` | ratio |",
            "|---|---|---|---|",
        ]
        for r in ground_rows:
            theirs = f"{r['mujoco'] * 1e6:.0f}" if np.isfinite(r["mujoco"]) else "-"
            ratio = f"{r['ratio']:.0f}" if np.isfinite(r["ratio"]) else "-"
            lines.append(f"| {r['scene']} | {r['ours'] * 1e6:.0f} | {theirs} | {ratio} |")
    return "\n".join(lines) + "\n"


def _ground_steps(paths, duration: float, folder: Path) -> list[dict]:
    """Scenes with ground contact: the mean wall time of our step over the first ``duration``
    seconds of the scene (the number of contacts changes as the body falls, so a single state
    would not be representative), against ``mj_step`` on the same fall in MuJoCo (its soft
    contacts, the Euler-mode body: :func:`humanoid.bench.peers.mujoco_fall`) in the same run.
    Scenes with a controller have no MuJoCo column (the controller is ours)."""
    from ..scene import Scene
    from ..simulation import Simulation
    from .peers import mujoco_fall

    try:
        import mujoco  # noqa: F401 - the peer is optional
    except ImportError:
        he = None
    else:
        he = load_male("euler")
    rows = []
    for path in paths:
        scene = Scene.load(path).replace(duration=duration, body=MALE)
        sim = Simulation(scene)
        traj = sim.run(quiet=True)
        ours = traj.metadata["wall_time"] / traj.metadata["steps"]
        theirs = float("nan")
        if he is not None and scene.controller.kind == "none":
            _, _, wall, _ = mujoco_fall(scene, sim.h, he, sim.q0, sim.v0, scene.dt, 10**9)
            theirs = wall / int(round(scene.duration / scene.dt))
        solves = traj.metadata["counters"].get("contact_solves", 1)
        rows.append({"scene": scene.name, "ours": ours, "mujoco": theirs,
                     "ratio": ours / theirs, "steps": solves})  # fmt: skip
    print(f"\nground contact (rigid, one frictional solve per step), mean over the first "
          f"{duration:g} s of each scene:")  # fmt: skip
    print(f"{'scene':<10} {'ours':>10} {'mj_step':>10} {'ratio':>7}   [us per step]")
    for r in rows:
        print(f"{r['scene']:<10} {r['ours'] * 1e6:>10.1f} {r['mujoco'] * 1e6:>10.1f} "
              f"{r['ratio']:>7.1f}")  # fmt: skip
    write_rows(folder / "step_ground.csv", rows, ["scene", "ours", "mujoco", "ratio", "steps"])
    print(f"wrote {folder / 'step_ground.csv'}")
    return rows
