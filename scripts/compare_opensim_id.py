"""Inverse dynamics of OpenSim's example walking trial on a body built from the subject's
height, mass and sex, beside OpenSim's own published result for it.

The trial is opensim-models' ``subject01_walk1`` (Pipelines/Gait2354_Simbody: the
coordinates from OpenSim's IK, ``subject01_walk1_ik.mot``; the force plates,
``subject01_walk1_grf.mot`` and ``.xml``; OpenSim's inverse dynamics of it,
``OutputReference/ResultsInverseDynamics/inverse_dynamics.sto``; the subject 1.8034 m and
72.6 kg, ``subject01_Setup_Scale.xml``). Get them from https://github.com/opensim-org/
opensim-models (the repository states no licence for its data, so the project does not ship
them) and run::

    python scripts/compare_opensim_id.py PATH/TO/opensim-models/Pipelines/Gait2354_Simbody

It prints, per generalised force, the range of ours and of OpenSim's, their correlation and the
RMS difference (on OpenSim's samples, the first and last 5 left out: the filters' ends).
"""

from __future__ import annotations

import argparse
import sys
import warnings
from pathlib import Path

import numpy as np

import humanoid
from humanoid.motion import read_storage
from humanoid.motion.coordinates import (
    MAPS,
    UnmappedWarning,
    configurations,
    generalized_forces_table,
)
from humanoid.motion.inverse_dynamics import inverse_dynamics
from humanoid.motion.loads import read_loads

COLUMNS = (
    "hip_flexion_r_moment", "hip_adduction_r_moment", "hip_rotation_r_moment",
    "knee_angle_r_moment", "ankle_angle_r_moment", "hip_flexion_l_moment",
    "hip_adduction_l_moment", "knee_angle_l_moment", "ankle_angle_l_moment",
    "lumbar_extension_moment", "pelvis_tx_force", "pelvis_ty_force", "pelvis_tz_force",
)  # fmt: skip


def compare(folder: Path, height: float, mass: float, sex: str, cutoff: float) -> dict:
    h = humanoid.load(humanoid.build_urdf(humanoid.BodyParameters(height, mass, sex)))
    ik = read_storage(folder / "subject01_walk1_ik.mot")
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", UnmappedWarning)  # mtp_angle: the foot is one segment
        t, q, _ = configurations(h, ik, MAPS["gait2354"])
    loads = read_loads(folder / "subject01_walk1_grf.mot")
    r = inverse_dynamics(h, t, q, loads, cutoff=cutoff)
    ours = generalized_forces_table(h, r.time, r.q, r.tau, MAPS["gait2354"])
    ref_dir = folder / "OutputReference" / "ResultsInverseDynamics"
    ref = read_storage(next(ref_dir.glob("*.sto")))
    inner = slice(5, -5)
    out = {}
    for c in COLUMNS:
        a = np.interp(ref.time, ours.time, ours.column(c))[inner]
        b = ref.column(c)[inner]
        out[c] = (a.min(), a.max(), b.min(), b.max(), float(np.corrcoef(a, b)[0, 1]),
                  float(np.sqrt(np.mean((a - b) ** 2))))  # fmt: skip
    return out


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("folder", type=Path, help="opensim-models' Pipelines/Gait2354_Simbody")
    p.add_argument("--height", type=float, default=1.8034)
    p.add_argument("--mass", type=float, default=72.6)
    p.add_argument("--sex", default="male")
    p.add_argument("--cutoff", type=float, default=6.0, help="as OpenSim's setup: 6 Hz")
    args = p.parse_args(argv)
    if not (args.folder / "subject01_walk1_ik.mot").exists():
        print(f"{args.folder}: no subject01_walk1_ik.mot (see --help)", file=sys.stderr)
        return 2
    rows = compare(args.folder, args.height, args.mass, args.sex, args.cutoff)
    print(
        f"{'generalised force':26s} {'ours [N m or N]':>18s} {'OpenSim':>18s} {'r':>6s} {'RMS':>6s}"
    )
    for c, (a0, a1, b0, b1, r, rms) in rows.items():
        print(f"{c:26s} {a0:8.1f} {a1:8.1f} {b0:8.1f} {b1:8.1f} {r:6.3f} {rms:6.1f}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
