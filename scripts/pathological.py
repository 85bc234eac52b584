"""A generated hemiparetic walk through inverse kinematics and tracking.

The male body walks 4 steps at 0.8 m/s; its right leg's swing is made a stroke survivor's:
the knee bends ``--stiff`` less (a stiff knee), the ankle drops ``--drop`` deg (a foot drop),
the hip abducts ``--abduct`` deg at mid-swing (circumduction) and the pelvis hikes ``--hike``
deg to clear the floor (tests/gait_variants.py); ``--slow`` stretches time. Its default
markers, with seeded noise of ``--noise`` metres, go through inverse kinematics and tracking
(``--reduce``: residual reduction with loads estimated on the floor first). It prints the
swing foot's lowest point and, per seed, the fit's and the tracked run's joints against the
walk (RMS), the root's worst error, whether tracking completed, and when it lost the motion
if it did::

    python scripts/pathological.py --seeds 0 1 2 3 4 [--rate 30 --noise 0.01] [--reduce]
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

import numpy as np
import pinocchio as pin

import humanoid as hm
from humanoid.data import BODIES
from humanoid.motion.ik import inverse_kinematics
from humanoid.motion.markers import MarkerTrajectories, default_markers, marker_positions
from humanoid.walking.gait import walk_on_ground

sys.path.insert(0, str(Path(__file__).resolve().parent.parent / "tests"))
from gait_variants import hemiparetic  # noqa: E402  (the generator the tests use)


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--seeds", type=int, nargs="+", default=[0, 1, 2])
    p.add_argument("--noise", type=float, default=0.005, help="[m] per coordinate")
    p.add_argument("--stiff", type=float, default=0.5)
    p.add_argument("--abduct", type=float, default=8.0)
    p.add_argument("--drop", type=float, default=8.0)
    p.add_argument("--lift", type=float, default=0.0)
    p.add_argument("--hike", type=float, default=5.0)
    p.add_argument("--slow", type=float, default=1.0)
    p.add_argument("--rate", type=float, default=100.0, help="[Hz] of the markers")
    p.add_argument("--reduce", action="store_true")
    args = p.parse_args(argv)
    from humanoid.motion.tracking import lost_at, track

    walk = walk_on_ground(hm.load(BODIES / "adult_male.urdf"), speed=0.8, steps=4,
                          record_rate=1000.0)  # fmt: skip
    h, tr = walk.body, walk.trajectory
    t, q, w = hemiparetic(h, tr.t, tr.q, tr.forces["ground_right"], args.stiff, args.abduct,
                          args.drop, args.slow, args.lift, args.hike)  # fmt: skip
    every = max(1, round(1000.0 / args.rate / args.slow))
    t, q, w = t[::every], q[::every], w[::every]
    markers = default_markers(h)
    names = list(markers)
    # the right sole's lowest point in swing (its toes' too)
    data = h.model.createData()
    lows = []
    for x in q[w > 0.0]:
        pin.framesForwardKinematics(h.model, data, x)
        lows.append(min(data.oMf[f].translation[2] for f in
                        (h.frame_id(n) for n in h.require_contact_points("right"))))  # fmt: skip
    print(f"{len(t)} frames at {1 / (t[1] - t[0]):.0f} Hz, {t[-1]:.2f} s; right swing's "
          f"lowest sole point {1e3 * min(lows):.1f} mm")  # fmt: skip
    clean = marker_positions(h, q, markers, names)

    def rms(qa, qb):
        d = np.array([pin.difference(h.model, a, b)[6:] for a, b in zip(qa, qb, strict=True)])
        return float(np.degrees(np.sqrt(np.mean(d**2))))

    for seed in args.seeds:
        rng = np.random.default_rng(seed)
        noisy = clean + rng.normal(scale=args.noise, size=clean.shape)
        start = time.perf_counter()
        fit = inverse_kinematics(h, MarkerTrajectories(t, names, noisy), markers)
        t_ik = time.perf_counter() - start
        tt, qq = t, fit.q
        if args.reduce:
            from humanoid.motion.floor import fit_floor
            from humanoid.motion.inverse_dynamics import derivatives, estimate_loads
            from humanoid.motion.reduce import reduce_residuals

            floor = fit_floor(h, t, fit.q)
            loads = estimate_loads(h, *derivatives(h.model, t, fit.q), floor=floor)
            red = reduce_residuals(h, t, fit.q, loads)
            weight = h.mass * 9.81
            print(f"  residual {100 * red.force_rms(after=False) / weight:.1f} -> "
                  f"{100 * red.force_rms() / weight:.1f} % BW RMS")  # fmt: skip
            tt, qq = red.time, red.q
        start = time.perf_counter()
        res = track(h, tt, qq)
        t_track = time.perf_counter() - start
        run = res.trajectory
        ref = q[np.clip(np.searchsorted(t, run.t + tt[0] - 1e-9), 0, len(q) - 1)]  # the walk's
        status = run.status + (f" ({run.metadata.get('message')})" if not res.completed else "")
        root = np.abs(res.joint_error[:, :3]).max()
        lost = lost_at(res.joint_error)
        if lost is not None:
            status += f", lost at {run.t[lost]:.2f} s"
        print(f"seed {seed}: fitted {rms(fit.q, q):.2f} deg RMS (IK {t_ik:.1f} s), tracked "
              f"{rms(run.q, ref):.2f} deg RMS, root max {1e3 * root:.0f} mm, {status} "
              f"(track {t_track:.1f} s)")  # fmt: skip
    return 0


if __name__ == "__main__":
    sys.exit(main())
