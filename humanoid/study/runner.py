"""One run of a study, as a worker does it: build the body, the scene or the walk, run it,
and give back one row: the run's parameters, its status and message, its summary numbers and
its wall time. Nothing a run does raises out of :func:`execute`: a fall, a divergence, a
failed controller or a bug is a row with its status (``completed``, ``fell``, ``diverged``,
``failed``, ``error``) and message.
"""

from __future__ import annotations

import math
import os
import socket
import time
import traceback
from pathlib import Path

import numpy as np
import pinocchio as pin

from ..errors import HumanoidError, RunFailed
from .build import PUSH_DEFAULTS, G, body_parameters, push_vector, scene_for
from .spec import OUTPUTS

__all__ = ["FALL_HEIGHT", "execute"]

# a run on the ground has fallen once its pelvis is below this fraction of its start height
# (a statue-like hold tipping over its toes is past recovery long before)
FALL_HEIGHT = 0.6
WALK_DEFAULTS = {"walk.steps": 10, "walk.dt": 1e-3, "walk.mu": 0.8}


def execute(payload: dict, run: dict, folder: str | None = None) -> dict:
    """Do one run. ``payload``: :meth:`Study.payload`; ``run``: index, id and params; the
    trajectory (keep = trajectory) goes to ``folder``/trajectories/ID.npz. Returns the row."""
    start = time.perf_counter()
    params = {**payload["fixed"], **run["params"]}
    row = {"run": run["id"], "index": run["index"], **run["params"]}
    outputs = dict.fromkeys(OUTPUTS[payload["run"]], math.nan)
    status, message, trajectory = "error", "", None
    try:
        if payload["run"] == "scene":
            status, message, values, trajectory = _scene_run(payload, params)
        else:
            status, message, values, trajectory = _walk_run(params)
        outputs.update(values)
    except HumanoidError as exc:
        status, message = "failed", str(exc)
    except Exception as exc:  # a bug or an unforeseen input: a row, never a crashed study
        last = traceback.extract_tb(exc.__traceback__)[-1]
        message = f"{type(exc).__name__}: {exc} ({Path(last.filename).name}:{last.lineno})"
    path = ""
    if trajectory is not None and payload["keep"] == "trajectory" and folder is not None:
        target = Path(folder) / "trajectories" / f"{run['id']}.npz"
        tmp = target.with_suffix(".part.npz")
        trajectory.save(tmp)
        os.replace(tmp, target)
        path = str(Path("trajectories") / target.name)
    row.update({"status": status, "message": message, **outputs})
    row.update({"wall_time": time.perf_counter() - start, "trajectory": path,
                "worker": f"{socket.gethostname()}:{os.getpid()}"})  # fmt: skip
    return row


class _FallMonitor:
    """Stops a run on the ground once the pelvis is below FALL_HEIGHT of its start height."""

    def __init__(self, z0: float) -> None:
        self.z0, self.fell_at = z0, math.nan

    def observe(self, sim, k, t, q, v, last) -> None:
        if last.q[2] < FALL_HEIGHT * self.z0:
            self.fell_at = float(last.t)
            raise RunFailed(f"the body fell at t = {last.t:.2f} s")


def _scene_run(payload: dict, params: dict):
    from ..simulation import Simulation, load_body

    scene = scene_for(payload, params, weight=None)
    h = load_body(scene)
    weight = h.mass * float(np.linalg.norm(h.model.gravity.linear))
    if "push.fraction" in params and body_parameters(params) is None:
        scene = scene_for(payload, params, weight=weight)
    sim = Simulation(scene, humanoid=h)
    monitor = None
    if scene.effects.ground is not None:
        monitor = _FallMonitor(float(sim.q0[2]))
    traj = sim.run(quiet=True, monitors=[monitor] if monitor is not None else [])
    status, message = traj.metadata["status"], traj.metadata["message"]
    fell_at = monitor.fell_at if monitor is not None else math.nan
    if not math.isnan(fell_at):
        status = "fell"
    model, data = h.model, h.model.createData()
    coms: list[np.ndarray] = []
    vcoms: list[np.ndarray] = []
    for q, v in zip(traj.q, traj.v, strict=True):
        pin.centerOfMass(model, data, q, v)
        coms.append(data.com[0].copy())
        vcoms.append(data.vcom[0].copy())
    com, vcom = np.array(coms), np.array(vcoms)
    z0 = float(traj.q[0, 2])
    push = scene.effects.pushes
    values = {
        "survived": bool(status == "completed"),
        "fell_at": fell_at,
        "t_end": float(traj.t[-1]) if len(traj.t) else 0.0,
        "pelvis_min": float(traj.q[:, 2].min() / z0) if z0 > 0 else math.nan,
        "com_travel": float(np.linalg.norm(com[-1, :2] - com[0, :2])),
        "peak_com_speed": float(np.linalg.norm(vcom, axis=1).max()),
        "push_force": float(np.linalg.norm(push[-1].force)) if push else 0.0,
        "mass": float(h.mass),
        "energy_change": float(traj.energy[-1] - traj.energy[0]),
        "final_speed": float(np.abs(traj.v[-1]).max()) if len(traj.v) else math.nan,
        "max_penetration": float(traj.metadata.get("max_penetration", math.nan)),
    }
    return status, message, values, traj


def _walk_run(params: dict):
    from ..body import build_urdf
    from ..model import load
    from ..scene import PushSpec
    from ..walking.gait import analyse, walk_on_ground
    from ..walking.norms import free_speed
    from ..walking.reference import fit_cycle, leg_length

    p = {**WALK_DEFAULTS, **params}
    body = body_parameters(p)
    h = load(build_urdf(body) if body is not None else "adult_male", ball_joints="quaternion")
    speed = p.get("walk.speed")
    if speed is None:
        speed = float(p.get("walk.speed_ratio", 1.0)) * free_speed(leg_length(h))
    cycle = fit_cycle(h, float(speed))
    pushes, force = [], 0.0
    if any(k.startswith("push.") for k in p):
        q = {**PUSH_DEFAULTS, **p}
        f = push_vector(q, h.mass * G)
        force = float(np.linalg.norm(f))
        fx, fy, fz = (float(x) for x in f)
        pushes = [PushSpec(q.get("push.frame", h.model.names[1]), (fx, fy, fz),
                           float(q["push.start"]), float(q["push.duration"]))]  # fmt: skip
    walk = walk_on_ground(h, float(speed), steps=int(p["walk.steps"]), cycle=cycle,
                          dt=float(p["walk.dt"]), mu=float(p["walk.mu"]),
                          pushes=pushes)  # fmt: skip
    traj = walk.trajectory
    status, message = traj.metadata["status"], traj.metadata["message"]
    fell_at = math.nan
    if not walk.completed and "fell" in message:
        status, fell_at = "fell", float(traj.t[-1])
    values = {"survived": bool(walk.completed), "fell_at": fell_at,
              "t_end": float(traj.t[-1]) if len(traj.t) else 0.0,
              "target_speed": float(speed), "push_force": force, "mass": float(h.mass)}  # fmt: skip
    if walk.completed:
        s = analyse(h, walk).summary
        values.update({k: float(s[k]) for k in ("speed", "cadence", "step_length",
                                                  "grf_first_peak", "slip")})  # fmt: skip
        values["cost_of_transport"] = cost_of_transport(h, traj)
    return status, message, values, traj


def cost_of_transport(h, traj) -> float:
    """Positive mechanical work of the joints over body weight times the distance walked:
    the integral of sum_j max(tau_j v_j, 0) over the run (trapezoid rule on the records) over
    m g times the pelvis's horizontal travel."""
    power = np.maximum(traj.tau * traj.v, 0.0).sum(axis=1)
    work = float(np.sum(0.5 * (power[1:] + power[:-1]) * np.diff(traj.t)))
    distance = float(np.linalg.norm(traj.q[-1, :2] - traj.q[0, :2]))
    return work / (h.mass * G * distance) if distance > 0 else math.nan
