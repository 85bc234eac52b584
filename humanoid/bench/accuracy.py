"""``humanoid bench accuracy``: what accuracy costs in time (work-precision diagrams).

The ODE community's format (DifferentialEquations.jl's WorkPrecisionSet): for each scene, every
method is swept over its step size (or tolerance); each run gives a point (wall time, error),
where the error is measured against a reference solution computed with the tightest setting of
the adaptive integrator, on the manifold (``pin.difference``). Besides the state error, each
run records the invariant drifts that the scene has: energy and angular momentum (conservative
scenes), constraint drift in position and velocity (|e| and |J v|, welded stance and walk) and
quaternion norm drift (coordinate formulation).

Scenes:

- ``tumble``: the body spinning in zero gravity, its joints moving (energy and momentum exact);
- ``swing``: one leg swinging freely from the floating body in zero gravity (a pendulum-like
  limb motion, energy exact);
- ``stance``: both feet welded, posture hold, pushed at the thorax (constraint drift);
- ``walk``: a two-step walking segment, the controller at a fixed 2 ms rate, the plant's
  integrator and step (or tolerance) swept; its reference is the adaptive integrator too, with
  2 ms ticks (the controller's rate, where the contacts switch);
- ``collapse``, ``drop`` and ``slide``: the shipped falls onto the floor (rigid ground contact
  for every body, joint ranges as constraints), their first second: the step and the contact
  solver's tolerance swept, MuJoCo's soft contacts beside them, default and stiffest (see
  :func:`_fall_rows`).

The error of a run is the largest state difference from the reference over all records (25 Hz),
on the manifold: max(|pin.difference(q_ref, q)|, |v - v_ref|).

Sweeps: the integrators over dt; the adaptive one over rtol; the Lie-group against the seeds'
coordinate quaternion formulation; no stabilisation against Baumgarte against projection; and
the stance without its Coriolis terms (a slow motion), which saves time and costs accuracy.
"""

from __future__ import annotations

import csv
import time
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import pinocchio as pin

from .common import (
    CONTROL_DT,
    MALE,
    RECORD_RATE,
    WALK_STEPS,
    load_male,
    run_scene,
    state_error,
)

__all__ = ["run_accuracy_benchmark", "run_fall_benchmark"]


@dataclass(frozen=True)
class Row:
    scene: str
    method: str
    setting: str
    wall: float  # [s]
    error: float  # largest state error against the reference over the records
    energy_drift: float  # relative
    momentum_drift: float  # relative (angular momentum about the CoM)
    constraint_drift: float  # [m or rad]
    velocity_drift: float  # largest |J v| of the constraints [m/s or rad/s]
    quaternion_drift: float  # max | |Q| - 1 |


def _scenes(quick: bool) -> dict:
    from ..scene import Contact, Controller, Effects, Initial, PushSpec, Scene, Stabilisation

    T = 0.5 if quick else 2.0
    rate = RECORD_RATE
    rng = np.random.default_rng(0)
    joint_v = tuple(float(x) for x in 0.5 * rng.normal(size=33))
    swing_v = [0.0] * 33
    swing_v[0] = 3.0  # left hip flexion component of the hip's angular velocity
    zero_g = (0.0, 0.0, 0.0)
    return {
        "tumble": Scene(
            name="tumble", body=MALE, duration=T, dt=1e-3, record_rate=rate,
            effects=Effects(gravity=zero_g),
            initial=Initial(base_velocity=(0, 0, 0, 0.3, 2.0, 0.5), joint_velocity=joint_v),
        ),
        "swing": Scene(
            name="swing", body=MALE, duration=T, dt=1e-3, record_rate=rate,
            effects=Effects(gravity=zero_g),
            initial=Initial(joint_velocity=tuple(swing_v)),
        ),
        "stance": Scene(
            name="stance", body=MALE, duration=T, dt=1e-3, record_rate=rate,
            effects=Effects(
                contacts=(Contact("left"), Contact("right")),
                # a window that is a whole number of every swept step (pushes are sampled per step)
                pushes=(PushSpec("thorax", (80.0, 20.0, 0.0), 0.0, 0.4 * T),),
            ),
            controller=Controller("posture", frequency=8.0),
            stabilisation=Stabilisation(baumgarte=20.0),
        ),
    }  # fmt: skip


def _momentum(h, q, v) -> np.ndarray:
    data = h.model.createData()
    return pin.computeCentroidalMomentum(h.model, data, q, v).angular.copy()


def _measure(name, method, setting, traj, wall, ref, h, conservative) -> Row:
    model = h.model
    q, v = traj.q[-1], traj.v[-1]
    error = np.inf
    if traj.status == "completed" and len(traj.t) == len(ref.t):
        assert np.allclose(traj.t, ref.t), "runs must be recorded at the same instants"
        error = state_error(model, ref, traj.q, traj.v)
    # invariants of the conservative scenes only
    energy: float | np.floating = np.nan
    momentum: float | np.floating = np.nan
    if conservative:
        e = traj.energy
        energy = abs(e[-1] - e[0]) / abs(e[0])
        L0, L1 = _momentum(h, traj.q[0], traj.v[0]), _momentum(h, q, v)
        momentum = np.linalg.norm(L1 - L0) / max(float(np.linalg.norm(L0)), 1e-12)
    quats = [jm.idx_q + (3 if jm.nq == 7 else 0) for jm in model.joints[1:] if jm.nq in (4, 7)]
    qd = max(abs(np.linalg.norm(traj.q[:, i : i + 4], axis=1) - 1.0).max() for i in quats)
    # the coordinate formulation records normalised quaternions; its raw drift is kept apart
    qd = max(qd, traj.metadata.get("quaternion_drift", 0.0))
    # the run's own largest residual: over the records for a scene, over every tick for a walk
    drift = float(traj.metadata.get("max_residual", np.nan))
    vdrift = float(traj.metadata.get("max_velocity_residual", np.nan))
    return Row(name, method, setting, wall, float(error), float(energy), float(momentum), drift,
               vdrift, float(qd))  # fmt: skip


def _scene_rows(h, name: str, scene, dts, tols) -> tuple[list[Row], float]:
    """One scene's sweeps against its DP5 reference: (its rows, the reference's convergence)."""
    from ..scene import Effects, Stabilisation

    rows: list[Row] = []
    conservative = name in ("tumble", "swing")
    ref_scene = scene.replace(integrator="adaptive", rtol=1e-12, atol=1e-12, dt=min(dts))
    ref, _ = run_scene(ref_scene, h)
    check, _ = run_scene(ref_scene.replace(rtol=1e-10, atol=1e-10, dt=2 * min(dts)), h)
    convergence = float(np.abs(pin.difference(h.model, ref.q[-1], check.q[-1])).max())

    def add(method, setting, sc, name=name, conservative=conservative, ref=ref):
        traj, wall = run_scene(sc, h)
        rows.append(_measure(name, method, setting, traj, wall, ref, h, conservative))
        print(f"  {name:<7} {method:<28} {setting:<12} {wall:8.3f} s  "
              f"error {rows[-1].error:.2e}", flush=True)  # fmt: skip

    for integrator in ("euler", "semi_implicit_euler", "rk4"):
        for dt in dts:
            add(integrator, f"dt={dt:g}", scene.replace(integrator=integrator, dt=dt))
    # the adaptive integrator chooses its steps inside each tick (contacts and effects are
    # updated per tick): long ticks where nothing switches, the reference's with contacts
    tick = min(dts) if name == "stance" else 0.04
    for tol in tols:
        add("adaptive (DP5)", f"rtol={tol:g}",
            scene.replace(integrator="adaptive", rtol=tol, atol=tol, dt=tick))  # fmt: skip
    if name == "tumble":
        for integrator in ("semi_implicit_euler", "rk4"):
            stab = Stabilisation(quaternions="coordinates")
            for dt in dts:
                variant = scene.replace(integrator=integrator, dt=dt, stabilisation=stab)
                add(f"{integrator}, coordinates", f"dt={dt:g}", variant)
    if name == "stance":
        for label, stab in (
            ("no stabilisation", Stabilisation()),
            ("baumgarte 20 dt", Stabilisation(baumgarte=20.0)),
            ("projection", Stabilisation(projection=True)),
        ):
            for dt in dts:
                variant = scene.replace(integrator="semi_implicit_euler", dt=dt, stabilisation=stab)
                add(f"semi-implicit, {label}", f"dt={dt:g}", variant)
        no_coriolis = Effects(**(vars(scene.effects) | {"coriolis": False}))
        for dt in dts:
            add("rk4, no Coriolis terms", f"dt={dt:g}",
                scene.replace(integrator="rk4", dt=dt, effects=no_coriolis))  # fmt: skip
    return rows, convergence


def _write_results(out: str | Path, rows: list[Row], convergence: dict) -> Path:
    """accuracy.csv, convergence.csv and a work-precision PNG per scene written in ``out``."""
    folder = Path(out)
    folder.mkdir(parents=True, exist_ok=True)
    _write_csv(folder / "accuracy.csv", rows)
    for name in convergence:
        _plot(name, [r for r in rows if r.scene == name], folder / f"accuracy_{name}.png")
    with open(folder / "convergence.csv", "w", newline="") as fh:
        csv.writer(fh).writerows([("scene", "reference_vs_rtol_1e-10"), *convergence.items()])
    print("reference convergence (DP5 at 1e-12 against 1e-10 with twice the tick, the walk's "
          "with the same 2 ms tick; final state):",
          ", ".join(f"{k} {v:.1e}" for k, v in convergence.items()))  # fmt: skip
    print(f"wrote {folder / 'accuracy.csv'}, convergence.csv and accuracy_<scene>.png")
    return folder


def _write_csv(path: Path, rows: list[Row], kept=()) -> None:
    """accuracy.csv: the header, the ``kept`` rows as read (lists of strings), then ``rows``."""
    fields = list(Row.__dataclass_fields__)
    with open(path, "w", newline="") as fh:
        w = csv.writer(fh)
        w.writerow(fields)
        w.writerows(kept)
        w.writerows([getattr(r, f) for f in fields] for r in rows)


def run_accuracy_benchmark(quick: bool = False, out: str | Path = "results/bench") -> int:
    """Run the sweeps, write accuracy.csv and one work-precision PNG per scene."""
    h = load_male()
    dts = (4e-3, 2e-3, 1e-3) if quick else (8e-3, 4e-3, 2e-3, 1e-3, 5e-4)
    tols = (1e-3, 1e-5, 1e-7) if quick else (1e-3, 1e-4, 1e-5, 1e-6, 1e-7, 1e-8)
    rows: list[Row] = []
    convergence = {}
    for name, scene in _scenes(quick).items():
        scene_rows, convergence[name] = _scene_rows(h, name, scene, dts, tols)
        rows += scene_rows

    walk_rows, convergence["walk"], walk_ref = _walking_rows(h, dts, tols)
    rows += walk_rows
    fall_rows, fall_convergence = _fall_rows(h, quick)
    rows += fall_rows
    convergence |= fall_convergence

    folder = _write_results(out, rows, convergence)
    try:
        import mujoco  # noqa: F401 - an optional extra
    except ImportError:
        print("MuJoCo is not installed (pip install humanoid[mujoco]): no peer comparison")
        return 0
    from .peers import run_peer_comparison

    print("\nagainst MuJoCo, in the same run:")
    run_peer_comparison(quick=quick, out=folder, walk=(walk_ref, walk_rows))
    return 0


def run_fall_benchmark(quick: bool = False, out: str | Path = "results/bench") -> int:
    """The falls alone (:func:`_fall_rows`), on one thread: their rows replace the falls' rows
    of ``out``/accuracy.csv (the other scenes' rows are kept as the last whole run wrote them)
    and their figures are drawn again."""
    from ..linalg import one_thread

    with one_thread():
        rows, convergence = _fall_rows(load_male(), quick)
    folder = Path(out)
    folder.mkdir(parents=True, exist_ok=True)
    path = folder / "accuracy.csv"
    kept = []
    if path.exists():
        with open(path, newline="") as fh:
            kept = [r for r in list(csv.reader(fh))[1:] if r and r[0] not in convergence]
    _write_csv(path, rows, kept)
    for name in convergence:
        _plot(name, [r for r in rows if r.scene == name], folder / f"accuracy_{name}.png")
    print(f"wrote the falls' rows into {path} and accuracy_<fall>.png")
    return 0


def _walk_run(h, integrator, dt, tol=1e-6):
    """(trajectory, wall time) of the walking segment with the controller at CONTROL_DT."""
    from ..walking import GaitParameters, walk

    start = time.perf_counter()
    result = walk(h, GaitParameters(steps=WALK_STEPS), dt=dt, integrator=integrator,
                  control_dt=CONTROL_DT, quiet=True, record_rate=RECORD_RATE, rtol=tol,
                  atol=tol, hold="torques")  # fmt: skip
    return result.trajectory, time.perf_counter() - start


def _walking_rows(h, dts, tols):
    """A walking segment (two steps, about 4.4 s) with the controller at a fixed 2 ms rate and
    the plant swept over integrators, steps and tolerances; the reference is the adaptive
    integrator at rtol = atol = 1e-12 (contacts switch, and the controller runs, every 2 ms).
    Returns the rows, the reference's convergence (against rtol 1e-10) and the reference."""
    ref, _ = _walk_run(h, "adaptive", CONTROL_DT, 1e-12)
    check, _ = _walk_run(h, "adaptive", CONTROL_DT, 1e-10)
    convergence = float(np.abs(pin.difference(h.model, ref.q[-1], check.q[-1])).max())
    rows = []

    def add(method, setting, traj, wall):
        rows.append(_measure("walk", method, setting, traj, wall, ref, h, False))
        print(f"  walk    {method:<28} {setting:<12} {wall:8.3f} s  "
              f"error {rows[-1].error:.2e}", flush=True)  # fmt: skip

    for integrator in ("semi_implicit_euler", "rk4"):
        for dt in [d for d in dts if d <= CONTROL_DT]:  # whole steps per control tick
            add(integrator, f"dt={dt:g}", *_walk_run(h, integrator, dt))
    for tol in tols:
        add("adaptive (DP5)", f"rtol={tol:g}", *_walk_run(h, "adaptive", CONTROL_DT, tol))
    return rows, convergence, ref


FALL_TOLERANCE = 1e-7  # the shipped fall scenes' contact-solver tolerance
KERNEL_TOLERANCE = 1e-6  # the compiled ADMM's: its residual is the problem's own (stricter)
LOOSE_TOLERANCE = 1e-3  # the compiled ADMM's step sweep again, loose: the cheapest it gets
FALLS = ("collapse", "drop", "slide")  # the shipped scenes of falls onto the floor


def _fall_rows(h, quick: bool):
    """The shipped falls (``collapse``: standing passive; ``drop``: from 0.5 m; ``slide``: tossed
    at 2 m/s onto ice, mu 0.1) for their first T seconds (the impacts and the fall itself): the
    step swept at the shipped solver tolerance, the tolerance swept at the shipped 1 ms step,
    and MuJoCo's soft contacts (Euler-mode body, :mod:`humanoid.bench.peers`) over the same
    steps, with its default parameters and its stiffest (solref 2 dt, solimp 0.9999: a
    millimetre deep or less, as ours). The reference: our scheme at a quarter of the smallest
    step and tolerance 1e-10 (first order in dt: its convergence is reported against twice its
    step). Pinocchio's PGS (``solver = "pgs"``) is swept over every other tolerance beside its
    ADMM, the compiled ADMM (``"kernel"``) over the tolerances and, at its own and at a loose
    one, the steps. The error is the configuration error (:func:`_configuration_error`).
    Returns the rows and the references' convergence."""
    from dataclasses import replace

    from ..scene import Scene

    T = 0.5 if quick else 1.0
    dts = (2e-3, 1e-3, 5e-4) if quick else (1e-2, 8e-3, 4e-3, 2e-3, 1e-3, 5e-4, 2.5e-4)
    tols = (1e-3, 1e-5, 1e-7) if quick else (1e-2, 1e-3, 1e-4, 1e-5, 1e-6, 1e-7, 1e-8, 1e-10)
    rows, convergence = [], {}
    try:
        import mujoco  # noqa: F401 - an optional extra

        from .peers import mujoco_fall

        he = load_male("euler")
    except ImportError:
        he = None
    for name in FALLS:
        base = Scene.load(name).replace(body=MALE)
        base = base.replace(duration=T, record_rate=RECORD_RATE)

        def variant(dt, tol, base=base, solver="admm"):
            ground = replace(base.effects.ground, tolerance=tol, solver=solver)
            return base.replace(dt=dt, effects=replace(base.effects, ground=ground))

        ref_dt = min(dts) / 4
        ref, _ = run_scene(variant(ref_dt, 1e-10), h)
        check, _ = run_scene(variant(2 * ref_dt, 1e-10), h)
        convergence[name] = _configuration_error(h.model, ref, check.q)

        def add(method, setting, traj, wall, name=name, ref=ref):
            row = _measure(name, method, setting, traj, wall, ref, h, False)
            error = _configuration_error(h.model, ref, traj.q) if np.isfinite(row.error) else (
                row.error)  # fmt: skip
            rows.append(replace(row, error=error, constraint_drift=traj.metadata.get(
                "max_penetration", row.constraint_drift)))  # fmt: skip
            print(f"  {name:<8} {method:<34} {setting:<12} {wall:8.3f} s  "
                  f"error {rows[-1].error:.2e}", flush=True)  # fmt: skip

        for dt in dts:
            add(f"ours, Pinocchio's ADMM, tolerance {FALL_TOLERANCE:g}", f"dt={dt:g}",
                *run_scene(variant(dt, FALL_TOLERANCE), h))  # fmt: skip
        for tol in tols:
            add(
                "ours, Pinocchio's ADMM, dt 1 ms", f"tol={tol:g}", *run_scene(variant(1e-3, tol), h)
            )
        for tol in tols[::2]:  # the other conic solver on the same problems
            add("ours, PGS, dt 1 ms", f"tol={tol:g}",
                *run_scene(variant(1e-3, tol, solver="pgs"), h))  # fmt: skip
        for tol in tols[:-1]:  # the compiled ADMM, warm-started (not at 1e-10: its floor)
            add("ours, compiled ADMM (default), dt 1 ms", f"tol={tol:g}",
                *run_scene(variant(1e-3, tol, solver="kernel"), h))  # fmt: skip
        for tol, what in ((KERNEL_TOLERANCE, " (default)"), (LOOSE_TOLERANCE, "")):
            for dt in dts:  # the step, at the compiled ADMM's tolerance and a loose one
                add(f"ours, compiled ADMM{what}, tolerance {tol:g}", f"dt={dt:g}",
                    *run_scene(variant(dt, tol, solver="kernel"), h))  # fmt: skip
        if he is None:
            continue
        for stiff, method in ((False, "MuJoCo soft contacts (Euler)"),
                              (True, "MuJoCo stiff contacts (Euler)")):  # fmt: skip
            for dt in dts:
                every = int(round(1.0 / (RECORD_RATE * dt)))
                q0, v0 = ref.q[0], ref.v[0]
                qs, vs, wall, depth = mujoco_fall(base, h, he, q0, v0, dt, every, stiff=stiff)
                states = [h.fusion.to_quaternion(q, v) for q, v in zip(qs, vs, strict=True)]
                traj = _Records([s[0] for s in states], [s[1] for s in states], ref.t,
                                {"max_penetration": depth})  # fmt: skip
                add(method, f"dt={dt:g}", traj, wall)
    return rows, convergence


def _configuration_error(model, ref, qs) -> float:
    """The largest configuration difference from the reference over the records,
    max |pin.difference(q_ref, q)|: with impacts the velocity jumps, and a jump a step
    earlier or later is an O(1) velocity error that says nothing of the accuracy, while the
    configuration stays continuous."""
    return max(np.abs(pin.difference(model, a, b)).max() for a, b in zip(ref.q, qs, strict=True))


@dataclass
class _Records:
    """States of another engine's run, in the shape :func:`_measure` reads."""

    q: list | np.ndarray  # (made arrays after init)
    v: list | np.ndarray
    t: np.ndarray
    metadata: dict
    status: str = "completed"

    def __post_init__(self) -> None:
        self.q, self.v = np.array(self.q), np.array(self.v)
        self.energy = np.full(len(self.t), np.nan)


def _plot(name: str, rows: list[Row], path: Path) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, axes = plt.subplots(1, 2, figsize=(11, 4.5), constrained_layout=True)
    methods = sorted({r.method for r in rows}, key=lambda m: [r.method for r in rows].index(m))
    second = "constraint_drift" if name in ("stance", "walk", *FALLS) else "energy_drift"
    labels = {"error": "state error vs reference", second: second.replace("_", " ")}
    if name in FALLS:
        labels[second] = "deepest penetration [m]"
    for ax, key in zip(axes, ("error", second), strict=True):
        for m in methods:
            pts = [(r.wall, getattr(r, key)) for r in rows if r.method == m]
            pts = [(w, e) for w, e in pts if np.isfinite(e) and e > 0]
            if pts:
                w, e = zip(*pts, strict=True)
                ax.loglog(w, e, "o-", label=m, ms=4)
        ax.set(xlabel="wall time [s]", ylabel=labels[key], title=f"{name}: {labels[key]}")
        ax.grid(alpha=0.3, which="both")
    axes[0].legend(fontsize=7)
    fig.savefig(path, dpi=80)
    plt.close(fig)
