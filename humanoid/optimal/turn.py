"""Walking along a circle: a whole stride optimised through the contact dynamics, periodic up to
a turn about the circle's centre.

A straight cycle bent onto a circle is not a motion of the body: turned rigidly with its pelvis,
its stance foot slides sideways and spins (a 2 m circle at 1.38 m/s turns the body 26 deg over
one stance), and nothing leans the body into the turn. Tracked so, the male body fell within
two steps on a 2 m circle (at 0.55 s with the centre of mass moved in by v^2 / (R omega^2), at
1.41 s without). So a turn is optimised as a gait is (:func:`~humanoid.optimal.gait.optimise_gait`,
the tracking objective) with these changes:

- the problem is a whole stride (six phases, the half stride's and their mirror: a turn is not
  left-right symmetric), its end its start turned about the circle's centre (0, R) by the
  stride's turn: the root's (x, y) and its velocity rotated, its yaw increased, every other
  coordinate and rate equal; the pelvis starts where the straight cycle's does (x = 0);
- the pelvis's rotation is tracked about the heading (which turns at a steady rate along the
  stride) and each foot's anterior force along it;
- the stride's turn is the straight cycle's distance over the radius: the speed along the
  circle and the cycle time are the straight cycle's;
- both double supports' events are tracked (the half stride tracks its one);
- the forces lie in a narrower friction pyramid (:data:`TURN_MU`) than the straight cycle's;
- the warm start is the straight cycle's stride bent onto the circle.

The stance feet then stay put while the hips turn the body over them, and the body leans into
the turn as its dynamics need. Designs measured on the male body and a 2 m circle: with the
pelvis's start free the optimum moved the pelvis in to a 1.63 m circle (1.14 m/s); with the
speed free down to half the straight cycle's the optimum slows to 80 % (1.11 m/s, the female's
1.03) and its push-off power falls below a person's; free down to 92 % it took 92 % (1.27 and
1.20 m/s: the female's speed and step below an adult's). Above 92 % the turns fell when tracked
until the tracker's footsteps corrected the centre of mass's position (``CycleGains.position``
in :mod:`humanoid.walking.person`); at the straight cycle's speed both walk 20 steps.
"""

from __future__ import annotations

import math

import numpy as np

from ..errors import ConvergenceError, OptimalControlError
from .cycle import (
    GaitSolution,
    Solution,
    TurnSolution,
    cache_dir,
    check_radius,
    rotation,
    save_turn,
    stored_turn,
    turn_file,
    turn_phases,
)  # fmt: skip
from .gait import ACCEPTABLE, RANGE_MARGIN, objective_terms
from .problem import Collocation

__all__ = ["TURN_MU", "optimise_turn", "turn"]

# the friction the turn's optimum may use, below the floor's 0.8: the optimum spreads a turn's
# sideways load over the points as it likes, the plant's contact solver as physics does.
# Tracked 20 steps (``CycleGains.position`` 1): planned at 0.8, the male's turn braked at
# 0.138 BW and its stances slid up to 3 mm, the female's 6 mm; planned at 0.6, 0.149 BW, 1 mm
# and 5 mm
TURN_MU = 0.6


def turn(gait: GaitSolution, radius: float, *, cache: bool = True,
         verbose: bool = False) -> TurnSolution:  # fmt: skip
    """``gait`` along a circle of ``radius`` [m] (positive turning left): from the package's
    data or the user's cache if one was made for this very cycle, else optimised
    (:func:`optimise_turn`) and, with ``cache``, stored.

    Raises:
        OptimalControlError: the radius is out of range. ConvergenceError: IPOPT did not
            converge.
    """
    radius = check_radius(radius)
    found = stored_turn(gait, radius)
    if found is not None:
        return found
    out = optimise_turn(gait, radius, verbose=verbose)
    s = out.solution
    if not s.success:
        raise ConvergenceError(f"the {gait.speed:.2f} m/s gait along a {radius:g} m circle did "
                            f"not converge: IPOPT {s.status} after {s.iterations} "
                            "iterations")  # fmt: skip
    if cache:
        save_turn(out, cache_dir() / turn_file(gait, radius))
    return out


def optimise_turn(gait: GaitSolution, radius: float, verbose: bool = False,
                  max_iter: int = 2000) -> TurnSolution:  # fmt: skip
    """The straight ``gait`` (tracking objective) along a circle of ``radius`` [m], positive
    turning left (see the module)."""
    from ..walking.norms import choose_gait
    from ..walking.reference import leg_length

    radius = check_radius(radius)
    if gait.objective != "tracking":
        raise OptimalControlError(f"a turn bends a tracking cycle, not a {gait.objective} one")
    om = gait.om
    durations = np.tile(gait.solution.durations, 2)
    nodes = tuple(gait.nodes)
    phases = turn_phases(om, durations, nodes, [(0.3 * d, 2.5 * d) for d in durations])
    c = Collocation(om, phases, mu=TURN_MU, periodic=True, range_margin=RANGE_MARGIN)
    opti, N = c.opti, c.N
    T = c.total_duration()
    opti.subject_to(T == gait.period)
    # the stride's turn: the straight cycle's stride along the circle
    theta = gait.speed * gait.period / radius
    R = rotation(theta)
    centre = np.array([0.0, radius])
    X, V = c.X, c.V
    # the pelvis at the heel strike where the straight cycle has it: its path's radius is then
    # ``radius`` on average (free, the optimum took the male body's in to 1.63 m on a 2 m
    # circle: the same turn on a shorter arc, 1.14 m/s)
    opti.subject_to(X[:2, 0] == gait.solution.x[0, :2])
    opti.subject_to(X[:2, N] == R @ (X[:2, 0] - centre) + centre)
    opti.subject_to(X[2, N] == X[2, 0])
    opti.subject_to(X[3, N] == X[3, 0] + theta)
    opti.subject_to(X[4:, N] == X[4:, 0])
    opti.subject_to(V[:2, N] == R @ V[:2, 0])
    opti.subject_to(V[2:, N] == V[2:, 0])
    c.warm_start(_bent(gait, radius))
    heading = [theta * t / T for t in c.node_times()]
    standing = om.from_body(om.body.standing_configuration())
    norms = choose_gait(gait.speed, leg_length(om.body))
    terms = objective_terms(c, om, "tracking", norms, standing, heading=heading)
    sol = c.solve(sum(terms.values()), terms=terms, verbose=verbose, max_iter=max_iter,
                  options=ACCEPTABLE)  # fmt: skip
    return TurnSolution(sol, gait, radius, nodes + nodes)


def _bent(gait: GaitSolution, radius: float) -> Solution:
    """The straight cycle's whole stride bent onto the circle: the pelvis at (x, y) to arc x on
    the circle of radius ``radius - y`` about (0, radius), its yaw and the forces turned by
    x / radius (the guess)."""
    t, x, v_straight, forces = gait.stride()
    x = x.copy()
    theta = x[:, 0] / radius
    r = radius - x[:, 1]
    x[:, 0], x[:, 1] = r * np.sin(theta), radius - r * np.cos(theta)
    x[:, 3] += theta
    v = np.gradient(x, t, axis=0)
    v[:, 2:] = v_straight[:, 2:]
    a = np.gradient(v, t, axis=0)
    turned = {}
    for p, f in forces.items():
        f = f.copy()
        f[:, :2] = np.einsum("kij,kj->ki", np.stack([rotation(th) for th in theta]), f[:, :2])
        turned[p] = f
    durations = np.tile(gait.solution.durations, 2)
    return Solution(t, x, v, a, np.zeros_like(x), turned, durations, False, "guess", 0, 0.0,
                    math.nan, math.nan, math.nan)  # fmt: skip
