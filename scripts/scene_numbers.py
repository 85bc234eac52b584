#!/usr/bin/env python3
"""The numbers of the ground-contact table (docs/simulation.md), measured on the shipped scenes
(records at 1 kHz): for the falls (``collapse``, ``drop``), the deepest point below the floor,
whether the energy ever rises, the kinetic energy at the end, the joint ranges' worst violation and
the contact solves at ADMM's iteration cap; and each shipped scene's cost (wall seconds per
simulated second, this machine, one thread).

Usage: python scripts/scene_numbers.py [SCENE ...]   (default: collapse drop)
"""

from __future__ import annotations

import sys

import numpy as np

import humanoid as hm
from humanoid.constraints.limits import JointRanges
from humanoid.data import SCENES
from humanoid.scene import Scene
from humanoid.simulation import load_body


def main(names) -> None:
    for name in names or ("collapse", "drop"):
        scene = Scene.load(SCENES / f"{name}.toml").replace(record_rate=1000.0)
        traj = hm.simulate(scene, quiet=True)
        meta = traj.metadata
        h = load_body(scene)
        ke = 0.5 * traj.v[-1] @ hm.mass_matrix(h, traj.q[-1]) @ traj.v[-1]
        ranges = JointRanges(h)
        worst = max(ranges.violation(q) for q in traj.q)
        print(
            f"{name}: {scene.duration:.0f} s, {meta['status']}; deepest point "
            f"{meta.get('max_penetration', 0.0) * 1e3:.3f} mm; energy rise "
            f"{max(0.0, float(np.diff(traj.energy).max())):.1e} J per step; kinetic energy at the "
            f"end {ke:.1e} J; ranges {np.degrees(worst):.1e} deg; capped solves "
            f"{meta.get('contact_solver_failures', 0)} of {meta['steps']}; cost "
            f"{meta['wall_time'] / scene.duration:.2f} s/s",
            flush=True,
        )


if __name__ == "__main__":
    main(sys.argv[1:])
