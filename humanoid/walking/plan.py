"""Gait plan: footsteps, timing, the ZMP reference, and swing-foot trajectories.

The walk starts and ends standing with the feet side by side. Steps alternate, right foot
first; footstep k (k = 1..n) lands at x = k L, except the last, which brings the feet together.
Timing: an initial double support (the centre of mass moves over the left foot), then for every
step a single support of ``t_single`` (the swing) and a double support of ``t_double`` (the load
moves to the new foot), then a final double support back to the middle of the feet.
The ZMP reference sits at the stance sole's centre in single support and moves smoothly to the
new foot during the first 80 % of each double support (and of the initial one's last 80 %), so
that a foot carries no load when it lifts off. Swing feet follow a quintic in x/y and a raised
cosine in z (zero velocity and acceleration at both ends: they land softly).
"""

from __future__ import annotations

import bisect
import math
from dataclasses import dataclass

import numpy as np

from ..errors import WalkError
from ..model import OTHER_SIDE

MAX_STEPS = 1000

__all__ = ["FootstepPlan", "GaitParameters"]

TRANSFER = 0.8  # fraction of a double support over which the ZMP moves to the new foot


@dataclass(frozen=True)
class GaitParameters:
    """Parameters of a straight walk.

    Attributes:
        steps: Number of steps (>= 2; the last brings the feet together).
        step_length: Distance between consecutive footsteps [m].
        t_single: Single-support (swing) duration [s].
        t_double: Double-support duration [s].
        step_height: Swing-foot clearance [m].
        t_start: Initial double support [s]. t_end: final double support [s].
    """

    steps: int = 10
    step_length: float = 0.35
    t_single: float = 0.5
    t_double: float = 0.15
    step_height: float = 0.05
    t_start: float = 2.0
    t_end: float = 1.2

    def __post_init__(self) -> None:
        if not (isinstance(self.steps, int) and 2 <= self.steps <= MAX_STEPS):
            raise WalkError(f"steps must be an integer in [2, {MAX_STEPS}], got {self.steps!r}")
        for name in ("step_length", "t_single", "t_double", "step_height", "t_start", "t_end"):
            value = getattr(self, name)
            if isinstance(value, bool) or not isinstance(value, int | float):
                raise WalkError(f"{name} must be a number, got {value!r}")
            if not (math.isfinite(value) and 0 < value <= 100):
                raise WalkError(f"{name} must be in (0, 100], got {value!r}")
        if self.step_length > 1.0:
            raise WalkError(f"step_length must be at most 1 m, got {self.step_length}")

    @property
    def period(self) -> float:
        """Time per step [s]."""
        return self.t_single + self.t_double

    @property
    def speed(self) -> float:
        """Average forward speed in steady walking [m/s]."""
        return self.step_length / self.period

    @classmethod
    def for_speed(cls, speed: float, **kw) -> GaitParameters:
        """Parameters with the step length that gives ``speed`` [m/s] at the default timing."""
        base = cls(**kw)
        return cls(**(kw | {"step_length": speed * base.period}))


@dataclass(frozen=True)
class Footstep:
    side: str  # the swinging foot
    start: np.ndarray  # where it lifts off (sole centre, x y) [m]
    target: np.ndarray  # where it lands [m]
    t_lift: float  # [s]
    t_land: float  # [s]


class FootstepPlan:
    """Footsteps and references of a walk.

    Args:
        gait: The gait parameters.
        left, right: Sole centres (x, y) of the feet at the start [m].
    """

    def __init__(self, gait: GaitParameters, left, right) -> None:
        self.gait = gait
        g = gait
        pos = {"left": np.array(left, dtype=float)[:2], "right": np.array(right, dtype=float)[:2]}
        self.initial = {k: v.copy() for k, v in pos.items()}
        self.steps: list[Footstep] = []
        t = g.t_start
        for k in range(1, g.steps + 1):
            side = "right" if k % 2 else "left"
            other = OTHER_SIDE[side]
            x = (k if k < g.steps else k - 1) * g.step_length + self.initial[side][0]
            if k == g.steps:
                x = pos[other][0]  # feet together
            target = np.array([x, self.initial[side][1]])
            self.steps.append(Footstep(side, pos[side].copy(), target, t, t + g.t_single))
            pos[side] = target
            t += g.period
        self.final = pos
        self.duration = self.steps[-1].t_land + g.t_end
        self._lifts = [s.t_lift for s in self.steps]
        # each step's stance foot where it stands during the step, and after the last step
        self._stance_at = [self._position_before(OTHER_SIDE[s.side], i)
                           for i, s in enumerate(self.steps)]  # fmt: skip
        self._stance_after = self._position_before(OTHER_SIDE[self.steps[-1].side], len(self.steps))

    # -- phases --------------------------------------------------------------------------
    def swing(self, t: float) -> Footstep | None:
        """The step whose foot is in the air at time t, if any (the steps are in time order
        and do not overlap: the last one lifted by t, if it has not landed)."""
        i = bisect.bisect_right(self._lifts, t) - 1
        return self.steps[i] if i >= 0 and t < self.steps[i].t_land else None

    def stance(self, t: float) -> set[str]:
        """Feet on the ground at time t."""
        s = self.swing(t)
        return {"left", "right"} - ({s.side} if s else set())

    def feet_at(self, t: float) -> dict[str, np.ndarray]:
        """Planned sole centres (x, y) at time t (swinging feet where they will land)."""
        pos = {k: v.copy() for k, v in self.initial.items()}
        for s in self.steps:
            if s.t_lift <= t:
                pos[s.side] = s.target.copy()
        return pos

    # -- references ----------------------------------------------------------------------
    def zmp(self, t: float) -> np.ndarray:
        """ZMP reference (x, y) [m]."""
        g = self.gait
        first = self.steps[0]
        mid0 = (self.initial["left"] + self.initial["right"]) / 2
        if t < first.t_lift:
            stance0 = self.initial[OTHER_SIDE[first.side]]
            s = _clip01((t - 0.2 * g.t_start) / (0.6 * g.t_start))
            return mid0 + smooth_step(s) * (stance0 - mid0)
        # the last step lifted by t, and the one before it (whose weight transfer may end a
        # rounding error after this one lifts)
        i = bisect.bisect_right(self._lifts, t) - 1
        for k in range(max(i - 1, 0), i + 1):
            step, stance = self.steps[k], self._stance_at[k]
            if step.t_lift <= t < step.t_land:
                return stance.copy()
            t_next = step.t_land + g.t_double
            if step.t_land <= t < t_next:
                if k == len(self.steps) - 1:
                    break
                # the load is on the new foot before the old one lifts off
                s = (t - step.t_land) / (TRANSFER * g.t_double)
                return stance + smooth_step(s) * (step.target - stance)
        last = self.steps[-1]
        stance = self._stance_after
        mid = (self.final["left"] + self.final["right"]) / 2
        s = _clip01((t - last.t_land) / (0.6 * g.t_end))
        return stance + smooth_step(s) * (mid - stance)

    def _position_before(self, side: str, i: int) -> np.ndarray:
        pos = self.initial[side].copy()
        for s in self.steps[:i]:
            if s.side == side:
                pos = s.target.copy()
        return pos

    def swing_reference(self, t: float):
        """(position, velocity, acceleration) of the swinging sole centre [m, m/s, m/s^2]."""
        step = self.swing(t)
        if step is None:
            return None
        T = step.t_land - step.t_lift
        tau = (t - step.t_lift) / T
        s, ds, dds = _quintic(tau)
        ds, dds = ds / T, dds / T**2
        d = step.target - step.start
        h = self.gait.step_height
        z = h * (1 - np.cos(2 * np.pi * s)) / 2
        dz = h * np.pi * np.sin(2 * np.pi * s) * ds
        ddz = h * np.pi * (2 * np.pi * np.cos(2 * np.pi * s) * ds**2 + np.sin(2 * np.pi * s) * dds)
        p = np.array([*(step.start + s * d), z])
        v = np.array([*(ds * d), dz])
        a = np.array([*(dds * d), ddz])
        return p, v, a


def smooth_step(s):
    """A smooth 0 -> 1 ramp with zero slope at both ends (the quintic)."""
    return _quintic(_clip01(s))[0]


def _clip01(x):
    """np.clip(x, 0, 1): for one number, the same float64 without NumPy's dispatch."""
    if isinstance(x, float):
        return np.float64(min(max(x, 0.0), 1.0))
    return np.clip(x, 0.0, 1.0)


def _quintic(tau):
    tau = _clip01(tau)
    s = 10 * tau**3 - 15 * tau**4 + 6 * tau**5
    ds = 30 * tau**2 - 60 * tau**3 + 30 * tau**4
    dds = 60 * tau - 180 * tau**2 + 120 * tau**3
    return s, ds, dds
