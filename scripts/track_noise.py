"""Physics-based tracking cleaning noisy markers, over several noise draws.

The male body walks 3 steps at 0.8 m/s (every step recorded, then every tenth: 100 Hz); its
default markers (or a keypoint layout's points) get Gaussian noise of ``--noise`` metres per
coordinate, seeded; inverse kinematics fits the body to them, and tracking follows that fit.
Per seed it prints whether the tracked run completed (and when it lost the motion, if it did)
and the joints' RMS error against the clean walk, of the fitted noisy motion and of the
tracked one::

    python scripts/track_noise.py --seeds 0 1 2 3 4 [--layout body25]
"""

from __future__ import annotations

import argparse
import sys

import numpy as np
import pinocchio as pin

import humanoid as hm
from humanoid.data import BODIES
from humanoid.motion.ik import inverse_kinematics
from humanoid.motion.markers import (
    KEYPOINT_LAYOUTS,
    MarkerTrajectories,
    default_markers,
    marker_positions,
)
from humanoid.motion.tracking import track
from humanoid.walking.gait import walk_on_ground


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--seeds", type=int, nargs="+", default=[0, 1, 2, 3, 4])
    p.add_argument("--noise", type=float, default=0.01, help="[m] per coordinate")
    p.add_argument("--layout", choices=sorted(KEYPOINT_LAYOUTS), help="keypoints, not markers")
    args = p.parse_args(argv)
    walk = walk_on_ground(hm.load(BODIES / "adult_male.urdf"), speed=0.8, steps=3,
                          record_rate=1000.0)  # fmt: skip
    h, tr = walk.body, walk.trajectory  # the body that walked (the fitted cycle's: toes locked)
    model = h.model
    t, q = tr.t[::10], tr.q[::10]
    markers = default_markers(h)
    names = list(markers) if args.layout is None else [
        n for n in KEYPOINT_LAYOUTS[args.layout] if n
    ]  # fmt: skip
    clean = marker_positions(h, q, markers, names)

    def rms(qa, qb):
        d = np.array([pin.difference(model, a, b)[6:] for a, b in zip(qa, qb, strict=True)])
        return float(np.degrees(np.sqrt(np.mean(d**2))))

    print(f"{len(names)} points, noise {args.noise * 1e3:.0f} mm, {len(t)} frames at 100 Hz")
    for seed in args.seeds:
        rng = np.random.default_rng(seed)
        noisy = clean + rng.normal(scale=args.noise, size=clean.shape)
        fit = inverse_kinematics(h, MarkerTrajectories(t, names, noisy), markers)
        res = track(h, t, fit.q)
        run = res.trajectory
        ref = q[np.clip(np.round(run.t * 100).astype(int), 0, len(q) - 1)]
        status = run.status + (f" ({run.metadata.get('message')})" if not res.completed else "")
        if res.lost is not None:
            status += f", lost the motion at {res.lost:.2f} s (its pelvis 10 cm or 15 deg off)"
        print(f"seed {seed}: fitted {rms(fit.q, q):.2f} deg RMS, tracked {rms(run.q, ref):.2f} "
              f"deg RMS, {status}")  # fmt: skip
    return 0


if __name__ == "__main__":
    sys.exit(main())
