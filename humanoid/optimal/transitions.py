"""Starting to walk from standing, and stopping to stand: transitions into and out of an
optimised gait cycle, by the same collocation (:mod:`.problem`).

- **Start** (:func:`optimise_start`), two steps as people take them (they reach their speed in
  two or three): from standing at rest, both feet flat, the body shifts its weight; the right
  foot swings while the left stays flat and then rolls onto its toes; the right lands, rolls
  flat and onto its toes while the left swings; the left's heel strike is the cycle's (the
  half stride's end, :attr:`~humanoid.optimal.cycle.Transition.join`).
- **Stop** (:func:`optimise_stop`), two steps: from the cycle's state at a right heel strike,
  the right foot loads and goes flat, the left swings a short step, the right swings beside it
  and lands flat, and the body comes to rest standing.

The swing legs follow the cycle's swing (:data:`SWING_SD`); the phases other than standing
last half to twice as long as the cycle's phases they repeat.

Each phase's duration is optimised. The objective is the predictive one's (effort, the
torques' rate, the joints' accelerations, the pelvis near level, the trunk and arms near
standing: :func:`~humanoid.optimal.gait.optimise_gait`), plus the two ends: the cycle's state
where the transition meets it, and rest in the standing posture at the other end, each as a
stiff penalty rather than an equality (the cycle's state already holds its feet on the floor:
equal states and contact rows on one node are dependent constraints, which IPOPT cannot take).
The x position where the transition meets the cycle is free.
"""

from __future__ import annotations

import math

import numpy as np

from ..errors import ConvergenceError
from ._casadi import ca
from .cycle import (
    GaitSolution,
    Transition,
    cache_dir,
    save_transition,
    stored_transition,
    transition_file,
    transition_phases,
)  # fmt: skip
from .gait import ACCEPTABLE, MU, RANGE_MARGIN, objective_terms
from .problem import Collocation

__all__ = ["optimise_start", "optimise_stop", "transition"]

SWING_SD = 10.0  # [deg] the swing leg follows the cycle's swing
# the ends' penalties: per rad^2 or m^2 from the state met, per (rad/s)^2 or (m/s)^2
W_JOIN = 1e3
W_JOIN_RATE = 10.0
W_REST_ACCELERATION = 1.0  # per (rad/s^2)^2 at the end at rest


def transition(gait: GaitSolution, kind: str, *, cache: bool = True,
               verbose: bool = False) -> Transition:  # fmt: skip
    """``gait``'s start (``kind="start"``) or stop: from the package's data or the user's cache
    if one was made for this very cycle, else optimised and, with ``cache``, stored.

    Raises:
        ConvergenceError: IPOPT did not converge (the message names its status).
    """
    found = stored_transition(gait, kind)
    if found is not None:
        return found
    tr = _optimise(gait, kind, verbose, 2000)
    s = tr.solution
    if not s.success:
        raise ConvergenceError(f"the {kind} of the {gait.speed:.2f} m/s gait did not converge: "
                            f"IPOPT {s.status} after {s.iterations} iterations")  # fmt: skip
    if cache:
        save_transition(tr, cache_dir() / transition_file(gait, kind))
    return tr


def optimise_start(gait: GaitSolution, verbose: bool = False, max_iter: int = 2000) -> Transition:
    """From standing at rest to ``gait``'s left heel strike (see the module)."""
    return _optimise(gait, "start", verbose, max_iter)


def optimise_stop(gait: GaitSolution, verbose: bool = False, max_iter: int = 2000) -> Transition:
    """From ``gait``'s right heel strike to standing at rest (see the module)."""
    return _optimise(gait, "stop", verbose, max_iter)


def _optimise(gait: GaitSolution, kind: str, verbose: bool, max_iter: int) -> Transition:
    om = gait.om
    phases = transition_phases(gait, kind)  # (it checks kind)
    c = Collocation(om, phases, mu=MU, periodic=False, range_margin=RANGE_MARGIN)
    N = c.N
    standing = _standing(om)
    # a start meets the cycle at its left heel strike (the half stride's end), a stop leaves it
    # at a right heel strike
    i = -1 if kind == "start" else 0
    x0, v0 = gait.solution.x[i], gait.solution.v[i]
    # the cycle's state where they meet, at rest standing at the other end
    meet, rest = (N, 0) if kind == "start" else (0, N)
    c.opti.subject_to(c.X[0, 0] == (0.0 if kind == "start" else x0[0]))
    join = W_JOIN * ca.sumsqr(c.X[1:, meet] - x0[1:]) + W_JOIN_RATE * ca.sumsqr(c.V[:, meet] - v0)
    at_rest = (W_JOIN * ca.sumsqr(c.X[2:, rest] - standing[2:])
               + W_JOIN_RATE * ca.sumsqr(c.V[:, rest])
               + W_REST_ACCELERATION * ca.sumsqr(c.A[:, rest]))  # fmt: skip
    # the predictive objective's terms are means over the cycle's time; a transition's time is
    # free, and its means would favour the longest (every phase ran to its upper bound): here,
    # integrals
    T = c.total_duration()
    terms = {k: T * v for k, v in objective_terms(c, om, "predictive", None, standing).items()}
    terms["join"] = join
    terms["rest"] = at_rest
    terms["swing"] = _swing(c, gait, kind)
    x_guess = _guess(standing, x0, kind, N, gait.step_length)
    durations = [ph.duration for ph in phases]
    t = np.concatenate([[0.0], np.cumsum(np.repeat(
        [d / ph.intervals for d, ph in zip(durations, phases, strict=True)],
        [ph.intervals for ph in phases]))])  # fmt: skip
    v_guess = np.gradient(x_guess, t, axis=0)
    c.guess(x_guess, v_guess, np.zeros_like(x_guess), durations=durations)
    sol = c.solve(sum(terms.values()), terms=terms, verbose=verbose, max_iter=max_iter,
                  options=ACCEPTABLE)  # fmt: skip
    return Transition(kind, sol, gait, tuple(phases))


def _swing(c: Collocation, gait: GaitSolution, kind: str):
    """The swing legs' joints against the cycle's swings at the same share of each phase, per
    :data:`SWING_SD` degrees squared, integrated: a start's right leg in its phases 2-3 and its
    left in 5-6, a stop's left leg in its phase 2."""
    om = gait.om
    t, x, _, _ = gait.stride()
    T = float(gait.solution.t[-1])
    d1, d2, d3 = (float(d) for d in gait.solution.durations)
    # (phase, side, the cycle's time at the phase's start, the cycle's phase's duration)
    segments: tuple[tuple[int, str, float, float], ...]
    if kind == "start":
        segments = ((1, "right", T + d1, d2), (2, "right", T + d1 + d2, d3),
                    (4, "left", d1, d2), (5, "left", d1 + d2, d3))  # fmt: skip
    else:
        segments = ((1, "left", d1, d2),)
    w = c.node_weights()
    starts = np.concatenate([[0], np.cumsum([ph.intervals for ph in c.phases])])
    out = 0
    for p, side, t0, d in segments:
        rows = [i for i, n in enumerate(om.names) if n.startswith(side) and any(
            j in n for j in ("hip", "knee", "ankle"))]  # fmt: skip
        n = c.phases[p].intervals
        for j in range(n + 1):
            target = np.array([np.interp(t0 + d * j / n, t, x[:, i]) for i in rows])
            out = out + w[starts[p] + j] * ca.sumsqr(c.X[rows, starts[p] + j] - target)
    return out / math.radians(SWING_SD) ** 2


def _standing(om) -> np.ndarray:
    """The body's standing posture in the OCP model's coordinates, kept the collocation's
    :data:`~humanoid.optimal.gait.RANGE_MARGIN` inside the joints' ranges (standing, the knees
    and elbows are at their limits)."""
    x = om.from_body(om.body.standing_configuration())
    lo, hi = om.model.lowerPositionLimit, om.model.upperPositionLimit
    ranged = np.isfinite(lo) & np.isfinite(hi) & (hi - lo < 100)
    margin = np.minimum(RANGE_MARGIN, 0.25 * (hi - lo))
    x[ranged] = np.clip(x[ranged], (lo + margin)[ranged], (hi - margin)[ranged])
    return x


def _guess(standing, x0, kind: str, N: int, step: float) -> np.ndarray:
    """Straight lines from standing to the cycle's state (a start) or back (a stop), the
    standing end about a step and a half behind (a start's two steps) or 0.9 of a step ahead (a
    stop's short step and the one beside it)."""
    stand = standing.copy()
    if kind == "start":
        stand[0] = 0.0
        end = x0.copy()
        end[0] = 1.3 * step
        a, b = stand, end
    else:
        stand[0] = x0[0] + 0.9 * step
        a, b = x0, stand
    s = np.linspace(0.0, 1.0, N + 1)[:, None]
    u = s * s * (3 - 2 * s)
    return a + u * (b - a)
