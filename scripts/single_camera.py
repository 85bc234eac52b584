"""Markerless motion from ONE calibrated camera, measured against the 3D truth.

The male body walks 2 steps at 0.8 m/s on the rigid ground (every step recorded, then every
33rd: 30 Hz); its BODY_25 (or HALPE 26) points are projected into one camera (1920x1080,
1400 px focal, a distorted lens) 5 m from the middle of the walk, at ``--view`` (``side``:
square to the walking direction; ``oblique``: 45 deg ahead of it, front and side), with
``--noise`` pixels of Gaussian noise, seeded. Inverse kinematics fits the body by reprojection
error from that one view, and tracking follows the fit in forward simulation. Per seed it
prints, against the walk itself: the joints' RMS error [deg] (all, and per group), the root's
position error along the camera's ray and across it [mm], the lowest sole point's height
(the feet floating or through the floor) [mm], for the fit and for the tracked run, and
whether tracking completed::

    python scripts/single_camera.py --view side oblique --seeds 0 1 2 3 4 [--no-track]

Writes a CSV row per view and seed to ``--out`` (default results/single_camera) and prints it.
"""

from __future__ import annotations

import argparse
import csv
import sys
import time
import warnings
from pathlib import Path

import numpy as np
import pinocchio as pin

import humanoid as hm
from humanoid.data import BODIES
from humanoid.motion.cameras import camera_keypoints, look_at
from humanoid.motion.coordinates import lowest_sole_point
from humanoid.motion.ik import inverse_kinematics
from humanoid.motion.inverse_dynamics import joint_labels
from humanoid.motion.markers import KEYPOINT_LAYOUTS, default_markers, marker_positions

RATE = 30.0
GROUPS = {
    "hips": ("hip_",),
    "knees": ("knee",),
    "ankles": ("ankle",),
    "trunk": ("lumbar", "thoracic"),
    "shoulders": ("shoulder",),
    "elbows": ("elbow",),
}
LENS = (-0.05, 0.01, 0.0005, -0.0003, 0.0)


def camera(view: str, middle, distance: float = 5.0, height: float = 1.6, **kw):
    """One camera ``distance`` [m] from ``middle`` (the walk's, walking along +x): ``side``
    square to the walk (on its right), ``oblique`` 45 deg ahead of it, ``front`` ahead."""
    angle = {"side": -90.0, "oblique": -45.0, "front": 0.0}[view]
    a = np.radians(angle)
    eye = np.array([middle[0] + distance * np.cos(a), middle[1] + distance * np.sin(a), height])
    return look_at(view, eye, (middle[0], middle[1], 0.9), distortions=LENS, **kw)


def errors(h, q_fit, q_true, cam) -> dict:
    """The fit's errors against the truth: joints RMS [deg] (all and per group), the pelvis's
    orientation RMS [deg], the root's position RMS along the camera's ray and across [mm],
    its along-ray error's frame-to-frame RMS change [mm] (jitter)."""
    model = h.model
    d = np.array([pin.difference(model, a, b) for a, b in zip(q_fit, q_true, strict=True)])
    labels = joint_labels(model)[6:]
    out = {"joints": float(np.degrees(np.sqrt(np.mean(d[:, 6:] ** 2))))}
    for g, words in GROUPS.items():
        cols = [6 + k for k, n in enumerate(labels) if any(w in n for w in words)]
        out[g] = float(np.degrees(np.sqrt(np.mean(d[:, cols] ** 2))))
    rot = np.array([pin.log3(pin.Quaternion(b[6], *b[3:6]).toRotationMatrix().T
                             @ pin.Quaternion(a[6], *a[3:6]).toRotationMatrix())
                    for a, b in zip(q_fit, q_true, strict=True)])  # fmt: skip
    out["pelvis"] = float(np.degrees(np.sqrt(np.mean(np.sum(rot**2, axis=1)))))
    ray = q_true[:, :3] - cam.centre
    u = ray / np.linalg.norm(ray, axis=1, keepdims=True)
    e = q_fit[:, :3] - q_true[:, :3]
    along = np.sum(e * u, axis=1)
    across = np.linalg.norm(e - along[:, None] * u, axis=1)
    out["along"] = float(np.sqrt(np.mean(along**2)) * 1e3)
    out["across"] = float(np.sqrt(np.mean(across**2)) * 1e3)
    out["jitter"] = float(np.sqrt(np.mean(np.diff(along) ** 2)) * 1e3)
    return out


def sole_heights(h, q) -> np.ndarray:
    """Each frame's lowest sole point [m] (0: a foot on the floor)."""
    return np.array([lowest_sole_point(h, qi[None]) for qi in q])


def project(h, q, cam, layout: str, noise: float, seed: int):
    """The walk's keypoints in ``cam`` with ``noise`` px, seeded: CameraKeypoints."""
    names = KEYPOINT_LAYOUTS[layout]
    keep = [i for i, n in enumerate(names) if n]
    full = np.full((len(q), len(names), 3), np.nan)
    full[:, keep] = marker_positions(h, q, default_markers(h), [names[i] for i in keep])
    uv = cam.project(full)[None]
    rng = np.random.default_rng(seed)
    uv = uv + rng.normal(scale=noise, size=uv.shape)
    conf = np.where(np.isfinite(uv[..., 0]), 0.9, 0.0)
    return uv, conf


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--view", nargs="+", default=["side", "oblique"],
                   choices=("side", "oblique", "front"))  # fmt: skip
    p.add_argument("--seeds", type=int, nargs="+", default=[0, 1, 2, 3, 4])
    p.add_argument("--noise", type=float, default=3.0, help="[px] per coordinate")
    p.add_argument("--layout", default="body25", choices=("body25", "halpe26"))
    p.add_argument("--ground", type=float, default=None, help="IK's floor weight (0: none)")
    p.add_argument("--smoothing", type=float, default=None, help="IK's joint smoothing [s^2]")
    p.add_argument("--root", type=float, default=None, help="IK's root depth smoothing [s^2]")
    p.add_argument("--no-stances", action="store_true",
                   help="IK without its second pass holding the planted feet still")  # fmt: skip
    p.add_argument("--no-track", action="store_true", help="inverse kinematics only")
    p.add_argument("--walk", help="a cached walk (.npz with t, q) instead of simulating it")
    p.add_argument("--out", default="results/single_camera")
    args = p.parse_args(argv)
    from humanoid.model import lock_foot_hinges

    h = lock_foot_hinges(hm.load(BODIES / "adult_male.urdf"))
    if args.walk:
        cached = np.load(args.walk)
        t, q = cached["t"], cached["q"]
    else:
        from humanoid.walking.gait import walk_on_ground

        walk = walk_on_ground(hm.load(BODIES / "adult_male.urdf"), speed=0.8, steps=2,
                              record_rate=1000.0)  # fmt: skip
        h, t, q = walk.body, walk.trajectory.t, walk.trajectory.q
    step = int(round(1000 / RATE))
    t, q = t[::step], q[::step]
    middle = 0.5 * (q[0, :3] + q[-1, :3])
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    rows = []
    truth_floor = sole_heights(h, q)
    for view in args.view:
        cam = camera(view, middle)
        for seed in args.seeds:
            uv, conf = project(h, q, cam, args.layout, args.noise, seed)
            kp = camera_keypoints(t, uv, conf, args.layout, [cam.name])
            start = time.perf_counter()
            with warnings.catch_warnings():
                warnings.simplefilter("ignore")
                kw = {} if args.smoothing is None else {"smoothing": args.smoothing}
                fit = inverse_kinematics(h, kp, default_markers(h), cameras=[cam],
                                         ground=args.ground, root_smoothing=args.root,
                                         stances=False if args.no_stances else None,
                                         **kw)  # fmt: skip
            wall = time.perf_counter() - start
            e = errors(h, fit.q, q, cam)
            low = sole_heights(h, fit.q) - truth_floor
            row = {"view": view, "seed": seed, "ik_s": round(wall, 1),
                   "px": round(float(np.sqrt(np.nanmean(fit.pixels**2))), 2),
                   **{f"ik_{k}": round(v, 1) for k, v in e.items()},
                   "ik_floor_mm": round(float(np.sqrt(np.mean(low**2))) * 1e3, 1)}  # fmt: skip
            if fit.depth is not None:
                row["flagged"] = int(fit.depth.weak.sum())
                row["depth_sd_mm"] = round(float(np.median(fit.depth.sd)) * row["px"] * 1e3, 1)
                if fit.depth.stances is not None:
                    row["stances"] = len(fit.depth.stances)
                    row["slid_mm"] = round(max((x.slide for x in fit.depth.stances),
                                               default=0.0) * 1e3)  # fmt: skip
            if not args.no_track:
                from humanoid.motion.tracking import track

                with warnings.catch_warnings():
                    warnings.simplefilter("ignore")
                    res = track(h, t, fit.q)
                run = res.trajectory
                row["completed"] = bool(res.completed)
                row["tracked_to_s"] = round(float(run.t[-1]), 2)
                k = np.clip(np.round(run.t * RATE).astype(int), 0, len(q) - 1)
                # the run in the reference's floor frame: tracking starts on the motion's
                # lowest sole point's plane (a fit's floor at most mm off the truth's)
                te = errors(res.body, run.q, q[k], cam)
                row |= {f"tr_{k2}": round(v, 1) for k2, v in te.items()}
                low_tr = sole_heights(res.body, run.q) - truth_floor[k]
                row["tr_floor_mm"] = round(float(np.sqrt(np.mean(low_tr**2))) * 1e3, 1)
            rows.append(row)
            print(row, flush=True)
    path = out / f"single_camera_{args.layout}_{args.noise:g}px.csv"
    with open(path, "w", newline="") as f:
        w = csv.DictWriter(f, fieldnames=list(dict.fromkeys(k for r in rows for k in r)))
        w.writeheader()
        w.writerows(rows)
    print(f"wrote {path}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
