"""OpenSim's example walking trial through the toolkit, on a body built from the subject's
height, mass and sex, beside OpenSim's own published results for it.

The trial is opensim-models' ``subject01_walk1`` (Pipelines/Gait2354_Simbody: the markers,
``subject01_walk1.trc``, and the static trial, ``subject01_static.trc``; the coordinates from
OpenSim's IK, ``subject01_walk1_ik.mot``; the force plates, ``subject01_walk1_grf.mot`` and
``.xml``; OpenSim's inverse dynamics of it,
``OutputReference/ResultsInverseDynamics/inverse_dynamics.sto``; the subject 1.8034 m and
72.6 kg, ``subject01_Setup_Scale.xml``). Get them from https://github.com/opensim-org/
opensim-models (the repository states no licence for its data, so the project does not ship
them) and run::

    python scripts/compare_opensim.py PATH/TO/opensim-models/Pipelines/Gait2354_Simbody

It prints three tables, each per coordinate or generalised force: the range of ours and of
OpenSim's, their correlation and the RMS difference (on OpenSim's samples; for the forces the
first and last 5 left out, the filters' ends):

1. ``id``: our inverse dynamics of OpenSim's IK coordinates, against OpenSim's ID;
2. ``ik``: our inverse kinematics of the markers (the default marker set, its technical
   markers registered on the static trial), against OpenSim's IK;
3. ``chain``: our inverse dynamics of our IK, against OpenSim's ID.
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
    coordinates_table,
    generalized_forces_table,
)
from humanoid.motion.ik import inverse_kinematics
from humanoid.motion.inverse_dynamics import inverse_dynamics
from humanoid.motion.loads import read_loads
from humanoid.motion.markers import default_markers, read_trc

COLUMNS = (
    "hip_flexion_r_moment", "hip_adduction_r_moment", "hip_rotation_r_moment",
    "knee_angle_r_moment", "ankle_angle_r_moment", "hip_flexion_l_moment",
    "hip_adduction_l_moment", "knee_angle_l_moment", "ankle_angle_l_moment",
    "lumbar_extension_moment", "pelvis_tx_force", "pelvis_ty_force", "pelvis_tz_force",
)  # fmt: skip


ANGLES = (
    "hip_flexion_r", "hip_adduction_r", "hip_rotation_r", "knee_angle_r", "ankle_angle_r",
    "hip_flexion_l", "knee_angle_l", "ankle_angle_l", "pelvis_tilt", "pelvis_list",
    "pelvis_rotation", "lumbar_extension",
)  # fmt: skip


def _rows(ours, ref, columns, inner) -> dict:
    out = {}
    for c in columns:
        a = np.interp(ref.time, ours.time, ours.column(c))[inner]
        b = ref.column(c)[inner]
        out[c] = (a.min(), a.max(), b.min(), b.max(), float(np.corrcoef(a, b)[0, 1]),
                  float(np.sqrt(np.mean((a - b) ** 2))))  # fmt: skip
    return out


def compare(folder: Path, height: float, mass: float, sex: str, cutoff: float) -> dict:
    h = humanoid.load(humanoid.build_urdf(humanoid.BodyParameters(height, mass, sex)))
    cmap = MAPS["gait2354"]
    ik = read_storage(folder / "subject01_walk1_ik.mot")
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", UnmappedWarning)  # mtp_angle: the foot is one segment
        t, q, _ = configurations(h, ik, cmap)
    loads = read_loads(folder / "subject01_walk1_grf.mot")
    ref = read_storage(next((folder / "OutputReference" / "ResultsInverseDynamics").glob("*.sto")))
    r = inverse_dynamics(h, t, q, loads, cutoff=cutoff)
    out = {"id": _rows(generalized_forces_table(h, r.time, r.q, r.tau, cmap), ref, COLUMNS,
                       slice(5, -5))}  # fmt: skip
    markers = default_markers(h)
    static = read_trc(folder / "subject01_static.trc")
    fit = inverse_kinematics(h, read_trc(folder / "subject01_walk1.trc"), markers,
                             register=True, static=static)  # fmt: skip
    out["ik"] = _rows(coordinates_table(h, fit.time, fit.q, cmap), ik, ANGLES, slice(None))
    rms = fit.frame_rms()
    out["ik residual"] = (float(np.nanmean(rms)), float(np.nanmax(rms)))
    r = inverse_dynamics(h, fit.time, fit.q, loads, cutoff=cutoff)
    out["chain"] = _rows(generalized_forces_table(h, r.time, r.q, r.tau, cmap), ref, COLUMNS,
                         slice(5, -5))  # fmt: skip
    return out


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("folder", type=Path, help="opensim-models' Pipelines/Gait2354_Simbody")
    p.add_argument("--height", type=float, default=1.8034)
    p.add_argument("--mass", type=float, default=72.6)
    p.add_argument("--sex", default="male")
    p.add_argument("--cutoff", type=float, default=6.0, help="as OpenSim's setup: 6 Hz")
    args = p.parse_args(argv)
    if not (args.folder / "subject01_walk1.trc").exists():
        print(f"{args.folder}: no subject01_walk1.trc (see --help)", file=sys.stderr)
        return 2
    tables = compare(args.folder, args.height, args.mass, args.sex, args.cutoff)
    mean, worst = tables.pop("ik residual")
    for name, rows in tables.items():
        unit = "deg" if name == "ik" else "N m or N"
        print(f"\n{name}: {'coordinate' if name == 'ik' else 'generalised force':22s} "
              f"{'ours [' + unit + ']':>18s} {'OpenSim':>18s} {'r':>6s} {'RMS':>6s}")  # fmt: skip
        for c, (a0, a1, b0, b1, r, rms) in rows.items():
            print(f"{c:30s} {a0:8.1f} {a1:8.1f} {b0:8.1f} {b1:8.1f} {r:6.3f} {rms:6.1f}")
        if name == "ik":
            print(
                f"(marker residual per frame: mean {mean * 1e3:.1f} mm, max {worst * 1e3:.1f} mm)"
            )
    return 0


if __name__ == "__main__":
    sys.exit(main())
