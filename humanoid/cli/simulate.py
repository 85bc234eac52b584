"""``humanoid simulate``: run a scene and save its trajectory; the run's summary."""

from __future__ import annotations

import math
import sys

from ..errors import HumanoidError

__all__ = ["add_simulate", "run_simulate", "run_summary"]


def add_simulate(command) -> None:
    """``humanoid simulate``: a scene run and saved."""
    from ..data import scene_names

    s = command("simulate", help="run a scene (TOML) and save the trajectory (.npz)")
    s.add_argument(
        "scene", help="a scene file, or a shipped scene's name: " + ", ".join(scene_names())
    )
    s.add_argument("-o", "--output", default="run.npz", help="trajectory file to write")
    s.add_argument("--duration", type=float, help="override the scene's duration [s]")
    s.add_argument("--quiet", action="store_true", help="no progress bar")


def run_simulate(args) -> int:
    from ..scene import Scene
    from ..simulation import simulate

    scene = Scene.load(args.scene)
    if args.duration is not None:
        scene = scene.replace(duration=args.duration)
    traj = simulate(scene, quiet=args.quiet)
    path = traj.save(args.output)
    print(run_summary(traj))
    print(f"saved        {path}")
    if traj.status != "completed":
        print(f"humanoid simulate: {traj.status}: {traj.metadata['message']}", file=sys.stderr)
        return 3
    return 0


def run_summary(traj) -> str:
    """Duration, steps, wall time, real-time factor, residual and energy drift of a run."""
    from ..run_metadata import RunMetadata

    m = RunMetadata.from_dict(traj.metadata)
    sim_time = float(traj.t[-1]) if len(traj.t) else 0.0
    # (a field the run did not record: no scene, no wall time, no events)
    scene = m.scene or {}
    wall = m.wall_time if m.wall_time is not None else math.nan
    drift = float(traj.energy[-1] - traj.energy[0]) if len(traj.energy) else float("nan")
    scale = max(abs(float(traj.energy[0])), 1.0) if len(traj.energy) else 1.0
    lines = [
        f"scene        {scene.get('name', '?')} ({m.status})",
        f"simulated    {sim_time:.3f} s in {m.steps} steps of {m.dt} s",
        f"wall time    {wall:.2f} s (real-time factor {sim_time / max(wall, 1e-9):.2f})",
        f"residual     {m.max_residual:.2e} (largest constraint position error, m or rad)",
        f"energy       {_energy_word(scene)} {drift:+.3e} J ({drift / scale:+.2e} relative)",
        f"events       {len(m.events or ())} contact events, violations {m.violations or 'none'}",
    ]
    return "\n".join(lines)


def _energy_word(scene: dict) -> str:
    """ "drift" where the run's scene conserves energy (an error of the integrator), else
    "change" with what takes or gives energy (:meth:`Scene.energy_exchanges`)."""
    from ..scene import Scene

    try:
        why = Scene.from_dict(scene).energy_exchanges()
    except HumanoidError:  # a run whose scene no longer reads: say nothing about the cause
        return "change:"
    return f"change ({', '.join(why)}):" if why else "drift"
