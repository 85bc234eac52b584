#!/usr/bin/env python3
"""Measure the person's walks and write the walking guide's tables of them (``make
walk-tables``).

Walks the shipped cycles on the rigid ground as docs/walking.md describes them (1 ms steps, one
BLAS thread a walk, two walks at a time) and writes one Markdown table per block of the guide
to ``docs/walks/NAME.md``; ``python scripts/readme_tables.py`` then pastes them into
docs/walking.md between its ``<!-- walk-NAME: begin -->`` / ``<!-- walk-NAME: end -->``
markers. The tables:

- ``cycles``: the shipped tracking and predictive cycles themselves (no walk);
- ``straight``: 20 steps of each default body at its free speed, with toes and one-piece feet;
- ``speeds``: the male body at each shipped speed, 20 steps;
- ``predictive``: the predictive cycles, 20 steps, and how far each number is from the adults';
- ``standing``: three strides from standing to standing;
- ``circle``: 20 steps along the 2 m circle;
- ``sizes``: the 1.50 m, 45 kg female and the 1.95 m, 100 kg male, 20 steps.

``python scripts/walk_tables.py [NAME ...]`` (default all); about 10 minutes on 2 cores.
"""

from __future__ import annotations

import sys
from concurrent.futures import ProcessPoolExecutor
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parent.parent
OUT = ROOT / "docs" / "walks"
STEPS = 20
BODIES = {"male": (1.75, 75.0), "female": (1.62, 62.0)}
SIZES = {
    "1.50 m, 45 kg female": (1.50, 45.0, "female"),
    "1.95 m, 100 kg male": (1.95, 100.0, "male"),
}
# the adults' bands (the tables' last rows; tests/casadi_gait_checks.py asserts them)
BANDS = {
    "speed": (1.27, 1.46), "cadence": (100, 120), "step_length": (0.66, 0.79),
    "stance": (0.58, 0.62), "double_support": (0.18, 0.26), "grf_first_peak": (1.05, 1.30),
    "grf_second_peak": (1.05, 1.30), "grf_trough": (0.60, 0.85), "braking": (0.15, 0.25),
    "propulsion": (0.15, 0.25), "ankle_moment_peak": (1.2, 1.6), "ankle_power_peak": (2.5, 4.5),
    "pelvis_obliquity": (6.7, 11.0), "pelvis_rotation": (5.9, 13.6),
}  # fmt: skip
ANGLES = ("hip_flexion", "knee_flexion", "ankle_dorsiflexion")
MOMENTS = ("hip_extension_moment", "knee_extension_moment", "ankle_plantarflexion_moment")


def _body(sex: str, toes: bool = True, size=None):
    import humanoid as hm

    if size is not None:
        return hm.load(hm.build_urdf(hm.BodyParameters(*size)))
    if toes:
        return hm.load(f"adult_{sex}")
    return hm.load(hm.build_urdf(hm.BodyParameters(*BODIES[sex], sex, toes=False)))


def walk(job: tuple) -> dict:
    """One walk (``job``: kind, sex, toes, speed, objective, size), measured."""
    import pinocchio as pin

    from humanoid.linalg import one_thread
    from humanoid.optimal.cycle import stored_gait
    from humanoid.walking.gait import analyse
    from humanoid.walking.norms import norms
    from humanoid.walking.person import walk_cycle, walk_from_standing

    kind, sex, toes, speed, objective, size = job
    h = _body(sex, toes, size)
    g = stored_gait(h, speed, objective)
    with one_thread():
        if kind == "standing":
            w = walk_from_standing(h, g, 3)
        else:
            w = walk_cycle(h, g, STEPS, radius=2.0 if kind == "circle" else None)
    a = analyse(h, w)
    out = {k: v for k, v in a.summary.items() if np.ndim(v) == 0}
    out["completed"] = w.completed
    out["free"] = speed is None
    out["real_time"] = w.real_time_factor
    for event, key in (("ipsilateral_foot_off", "stance"), ("double_support", "double_support")):
        out[f"{key}_norm"] = norms().event(event, a.dimensionless_speed)[0]
    tr = w.trajectory
    if kind == "circle":
        r = np.linalg.norm(tr.q[:, :2] - (0.0, 2.0), axis=1)
        out["radius"] = (float(r.min()), float(r.max()))
    if kind == "standing":
        model, data = h.model, h.model.createData()
        speeds = []
        for q, v in zip(tr.q, tr.v, strict=True):
            pin.centerOfMass(model, data, q, v)
            speeds.append(float(np.linalg.norm(data.vcom[0])))
        speeds = np.array(speeds)
        moving = np.flatnonzero(speeds >= 0.01)
        k = moving[-1] + 1 if len(moving) else 0
        out["rest"] = (float(speeds[k:].max()), float(tr.t[min(k, len(tr.t) - 1)]), float(tr.t[-1]))
        out["top_speed"] = (float(speeds.max()), float(tr.t[int(np.argmax(speeds))]))
    return out


def _range(s: dict, names) -> str:
    v = [100 * s[f"{n}_in_band"] for n in names]
    return f"{min(v):.0f}" if round(min(v)) == round(max(v)) else f"{min(v):.0f}-{max(v):.0f}"


def _off(s: dict, key: str, fmt: str, scale: float = 1.0, unit: str = "") -> str:
    """``s[key]`` with how far it is outside the adults' band, e.g. ``51.7 % (-6.3)``."""
    lo, hi = BANDS[key]
    value = s[key]
    text = format(value * scale, fmt) + unit
    if value < lo:
        text += f" ({(value - lo) * scale:+{fmt}})"
    elif value > hi:
        text += f" ({(value - hi) * scale:+{fmt}})"
    return text


def _common(s: dict) -> list[str]:
    return [
        f"{s['speed']:.2f} m/s", f"{s['cadence']:.0f} /min", f"{s['step_length']:.3f} m",
        f"{100 * s['stance']:.1f} %", f"{100 * s['double_support']:.1f} %",
        f"{s['grf_first_peak']:.2f}, {s['grf_second_peak']:.2f} / {s['grf_trough']:.2f} BW",
        f"{s['braking']:.2f} / {s['propulsion']:.2f} BW",
    ]  # fmt: skip


def _row(cells) -> str:
    return "| " + " | ".join(cells) + " |\n"


def _head(*names) -> str:
    return _row(names) + _row(["---"] * len(names))


ADULTS = ("1.27-1.46", "100-120", "0.66-0.79", "58-62 %", "18-26 %", "1.05-1.30 / 0.60-0.85",
          "0.15-0.25")  # fmt: skip


def cycles() -> str:
    sys.path.insert(0, str(ROOT / "tests"))
    from casadi_gait_checks import _cycle_numbers

    from humanoid.optimal.cycle import stored_gait

    text = _head("body", "speed", "cadence", "step", "stance", "double support",
                 "GRF peaks / trough", "braking / propulsion", "ankle moment",
                 "ankle power")  # fmt: skip
    rows = [(f"{sex} {h:.2f} m, {m:.0f} kg (shipped, toes)", sex, True, "tracking")
            for sex, (h, m) in BODIES.items()]  # fmt: skip
    rows += [(f"{sex}, one-piece feet", sex, False, "tracking") for sex in BODIES]
    rows += [(f"{sex}, predictive", sex, True, "predictive") for sex in BODIES]
    for label, sex, toes, objective in rows:
        g = stored_gait(_body(sex, toes), None, objective)
        n = _cycle_numbers(g)
        text += _row([
            label, f"{g.speed:.2f} m/s", f"{g.cadence:.1f} /min", f"{g.step_length:.3f} m",
            f"{100 * n['stance']:.1f} %", f"{100 * n['double_support']:.1f} %",
            f"{n['first_peak']:.2f}, {n['second_peak']:.2f} / {n['trough']:.2f} BW",
            f"{n['braking']:.2f} / {n['propulsion']:.2f} BW", f"{n['ankle_moment']:.2f} N m/kg",
            f"{n['ankle_power']:.2f} W/kg",
        ])  # fmt: skip
    return text + _row(["adults (norms)", *ADULTS, "1.2-1.6", "2.5-4.5"])


def _jobs(name: str) -> list[tuple]:
    from humanoid.optimal.cycle import SHIPPED_SPEEDS

    if name == "straight":
        return [("walk", s, toes, None, "tracking", None) for toes in (True, False) for s in BODIES]
    if name == "speeds":
        return [("walk", "male", True, v, "tracking", None) for v in (*SHIPPED_SPEEDS, None)]
    if name == "predictive":
        return [("walk", s, True, None, "predictive", None) for s in BODIES]
    if name in ("standing", "circle"):
        return [(name, s, True, None, "tracking", None) for s in BODIES]
    if name == "sizes":
        return [("walk", size[2], True, None, "tracking", size) for size in SIZES.values()]
    return []


def table(name: str, results: list[dict]) -> str:
    """The Markdown table ``name`` of the walks of :func:`_jobs` (in its order)."""
    if name == "straight":
        text = _head("body", "speed", "cadence", "step", "stance", "double support",
                     "GRF peaks / trough", "braking / propulsion", "ankle moment", "ankle power",
                     "pelvic obliquity / rotation", "real time")  # fmt: skip
        labels = ["male (shipped, toes)", "female (shipped, toes)", "male, one-piece feet",
                  "female, one-piece feet"]  # fmt: skip
        for label, s in zip(labels, results, strict=True):
            text += _row([label, *_common(s), f"{s['ankle_moment_peak']:.2f} N m/kg",
                          f"{s['ankle_power_peak']:.2f} W/kg",
                          f"{s['pelvis_obliquity']:.1f} / {s['pelvis_rotation']:.1f} deg",
                          f"{s['real_time']:.2f}"])  # fmt: skip
        text += _row(["adults", *ADULTS, "1.2-1.6", "2.5-4.5", "6.7-11.0 / 5.9-13.6", ""])
        text += (
            "\nInside Schwartz's band (mean +- 2 SD, `GaitAnalysis.in_band`), hip, knee, ankle:\n\n"
        )
        for label, s in zip(labels, results, strict=True):
            angles = ", ".join(f"{100 * s[f'{n}_in_band']:.0f}" for n in ANGLES)
            moments = ", ".join(f"{100 * s[f'{n}_in_band']:.0f}" for n in MOMENTS)
            text += (f"- {label}: angles {angles} % of the cycle, moments {moments} %; "
                     f"roughness {s['roughness']:.1f}; knee flexion in loading "
                     f"{s['knee_loading']:.1f} deg; arms {s['shoulder_flexion']:.1f} deg "
                     f"(r {s['arm_leg_correlation']:.2f} with their hips)\n")  # fmt: skip
        return text
    if name == "speeds":
        text = _head("speed", "cadence", "step", "stance (norm)", "double support (norm)",
                     "GRF peaks / trough", "braking / propulsion", "ankle moment, power",
                     "angles / moments in band")  # fmt: skip
        order = sorted(results, key=lambda s: s["speed"])
        for s in order:
            c = _common(s)
            c[0] += " (free)" if s["free"] else ""
            c[3] = f"{100 * s['stance']:.1f} % ({100 * s['stance_norm']:.1f})"
            c[4] = f"{100 * s['double_support']:.1f} % ({100 * s['double_support_norm']:.1f})"
            text += _row([*c, f"{s['ankle_moment_peak']:.2f}, {s['ankle_power_peak']:.2f}",
                          f"{_range(s, ANGLES)} / {_range(s, MOMENTS)} %"])  # fmt: skip
        text += "\nFrom the slowest to the fastest: pelvic obliquity " + ", ".join(
            f"{s['pelvis_obliquity']:.1f}" for s in order) + " deg; rotation " + ", ".join(
            f"{s['pelvis_rotation']:.1f}" for s in order) + " deg; arm swing " + ", ".join(
            f"{s['shoulder_flexion']:.1f}" for s in order) + " deg.\n"  # fmt: skip
        return text
    if name == "predictive":
        text = _head("body", "speed", "cadence", "step", "stance", "double support",
                     "GRF peaks / trough", "braking / propulsion", "ankle moment, power",
                     "angles / moments in band", "pelvic obliquity / rotation",
                     "arm swing")  # fmt: skip
        for label, s in zip(BODIES, results, strict=True):
            text += _row([
                label, _off(s, "speed", ".2f", unit=" m/s"),
                _off(s, "cadence", ".0f", unit=" /min"),
                _off(s, "step_length", ".3f", unit=" m"),
                _off(s, "stance", ".1f", 100, " %"),
                _off(s, "double_support", ".1f", 100, " %"),
                f"{_off(s, 'grf_first_peak', '.2f')}, "
                f"{_off(s, 'grf_second_peak', '.2f')} / "
                f"{_off(s, 'grf_trough', '.2f')} BW",
                f"{_off(s, 'braking', '.2f')} / "
                f"{_off(s, 'propulsion', '.2f')} BW",
                f"{_off(s, 'ankle_moment_peak', '.2f')}, "
                f"{_off(s, 'ankle_power_peak', '.2f')}",
                f"{_range(s, ANGLES)} / {_range(s, MOMENTS)} %",
                f"{_off(s, 'pelvis_obliquity', '.1f')} / "
                f"{_off(s, 'pelvis_rotation', '.1f')} deg",
                f"{s['shoulder_flexion']:.0f} deg (r {s['arm_leg_correlation']:.2f})",
            ])  # fmt: skip
        return text
    last = {"standing": "at rest", "circle": "pelvis on the circle",
            "sizes": "moments in band (hip, knee, ankle)"}[name]  # fmt: skip
    text = _head("body", "speed", "cadence", "step", "stance", "double support",
                 "GRF peaks / trough", "braking / propulsion", "ankle moment, power",
                 *(() if name == "sizes" else ("angles / moments in band",)), last)  # fmt: skip
    labels = list(SIZES) if name == "sizes" else list(BODIES)
    for label, s in zip(labels, results, strict=True):
        if name == "standing":
            v, t, end = s["rest"]
            end_cell = f"{v:.3f} m/s from {t:.1f} s (of {end:.1f})"
        elif name == "circle":
            end_cell = f"{s['radius'][0]:.2f}-{s['radius'][1]:.2f} m"
        else:
            end_cell = ", ".join(f"{100 * s[f'{n}_in_band']:.0f}" for n in MOMENTS) + " %"
        cells = [label, *_common(s), f"{s['ankle_moment_peak']:.2f}, {s['ankle_power_peak']:.2f}"]
        if name != "sizes":
            cells.append(f"{_range(s, ANGLES)} / {_range(s, MOMENTS)} %")
        text += _row([*cells, end_cell])
    text += "\n"
    for label, s in zip(labels, results, strict=True):
        text += (f"- {label}: largest slide of a stance {1e3 * s['slip']:.1f} mm, "
                 f"{100 * s['heel_to_toe']:.0f} % of the stances heel to toe")  # fmt: skip
        if name == "standing":
            top, at = s["top_speed"]
            text += f"; the centre of mass's top speed {top:.2f} m/s at {at:.1f} s"
        text += "\n"
    return text


NAMES = ("cycles", "straight", "speeds", "predictive", "standing", "circle", "sizes")


def main(names) -> int:
    names = names or list(NAMES)
    unknown = [n for n in names if n not in NAMES]
    if unknown:
        print(f"walk_tables: no table {unknown[0]!r}; there are {', '.join(NAMES)}",
              file=sys.stderr)  # fmt: skip
        return 2
    OUT.mkdir(parents=True, exist_ok=True)
    if "cycles" in names:
        (OUT / "cycles.md").write_text(cycles())
        print("cycles: written", flush=True)
    walks = [n for n in names if n != "cycles"]
    jobs = {n: _jobs(n) for n in walks}
    flat = list(dict.fromkeys(j for n in walks for j in jobs[n]))  # (the free speed's twice)
    with ProcessPoolExecutor(2) as pool:
        results = dict(zip(flat, pool.map(walk, flat), strict=True))
    status = 0
    for n in walks:
        rows = [results[j] for j in jobs[n]]
        for j, s in zip(jobs[n], rows, strict=True):
            if not s["completed"]:
                print(f"{n}: the walk {j} did not complete", file=sys.stderr)
                status = 1
        (OUT / f"{n}.md").write_text(table(n, rows))
        print(f"{n}: written", flush=True)
    return status


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
