"""Optimise the gait cycles the package ships (``make gaits``): the default bodies, as shipped
(with toes) and with one-piece feet (``--no-toes``), at their free speed from scratch, and the
bodies with toes at :data:`~humanoid.optimal.cycle.SHIPPED_SPEEDS`, each warm-started from its
neighbour towards the free speed, into ``humanoid/data/gaits``; the tracking objective, and for
the bodies with toes at their free speed the predictive one too (from the tracking optimum),
and the start from standing, the stop to standing and the turn along a circle of each radius in
:data:`RADII` of their free-speed tracking cycle; and the free-speed tracking cycles of the
small and the tall body of :data:`SIZES` (the 1.50 m, 45 kg female and the 1.95 m, 100 kg male
that ``make test`` walks).

Run from the repository: ``python scripts/make_gaits.py [BODY ...]`` (default all of
:data:`BODIES`); ``--transitions BODY ...`` solves only the starts, stops and turns, of the
cycles already shipped. Each line printed says what was solved, in how many iterations and seconds,
and the collocation's largest defect.
"""

from __future__ import annotations

import sys

import humanoid as hm
from humanoid.optimal.cycle import (
    DATA,
    KINDS,
    SHIPPED_SPEEDS,
    TurnSolution,
    gait_file,
    save_gait,
    save_transition,
    save_turn,
    stored_gait,
    transition_file,
    turn_file,
)  # fmt: skip
from humanoid.optimal.gait import optimise_gait
from humanoid.optimal.transitions import optimise_start, optimise_stop
from humanoid.optimal.turn import optimise_turn

BODIES = {  # name: the shipped body's name, and whether it has toes
    "adult_male": ("adult_male", True),
    "adult_female": ("adult_female", True),
    "adult_male_no_toes": ("adult_male", False),
    "adult_female_no_toes": ("adult_female", False),
    "small_female": ("small_female", True),
    "tall_male": ("tall_male", True),
}
# bodies of other sizes: (height [m], mass [kg], sex); only their free-speed tracking cycle
SIZES = {"small_female": (1.50, 45.0, "female"), "tall_male": (1.95, 100.0, "male")}
RADII = (2.0,)  # [m] the turns shipped (positive: to the left)
SHIPPED = {"adult_male": (1.75, 75.0, "male"), "adult_female": (1.62, 62.0, "female")}


def main(names) -> int:
    only_transitions = "--transitions" in names
    names = [n for n in names if n != "--transitions"]
    for name in names or BODIES:
        if name not in BODIES:
            print(f"make_gaits: no body {name!r}; there are {', '.join(BODIES)}", file=sys.stderr)
            return 2
        body, toes = BODIES[name]
        if body in SIZES:
            h = hm.load(hm.build_urdf(hm.BodyParameters(*SIZES[body])))
        elif toes:
            h = hm.load(body)
        else:
            h = hm.load(hm.build_urdf(hm.BodyParameters(*SHIPPED[body], toes=False)))
        free = stored_gait(h) if only_transitions else optimise_gait(h, None, "tracking")
        if free is None or not (only_transitions or _saved(name, free)):
            return 1
        if not toes or body in SIZES:
            continue
        for kind, solve in zip(KINDS, (optimise_start, optimise_stop), strict=True):
            tr = solve(free)
            if not _saved(f"{name} {kind}", tr, transition_file(free, kind)):
                return 1
        for radius in RADII:
            turn = optimise_turn(free, radius)
            if not _saved(f"{name} turn {radius:g} m ({turn.speed:.2f} m/s)", turn,
                          turn_file(free, radius)):  # fmt: skip
                return 1
        if only_transitions:
            continue
        if not _saved(name, optimise_gait(h, free.speed, "predictive", warm=free)):
            return 1
        # warm chains: down from the free speed, and up from it
        for chain in (sorted((v for v in SHIPPED_SPEEDS if v < free.speed), reverse=True),
                      sorted(v for v in SHIPPED_SPEEDS if v > free.speed)):  # fmt: skip
            warm = free
            for speed in chain:
                warm = optimise_gait(h, speed, "tracking", warm=warm)
                if not _saved(name, warm):
                    return 1
    return 0


def _saved(name: str, g, file: str | None = None) -> bool:
    """Print what was solved (a gait, or a transition or turn to store as ``file``); store it
    if IPOPT succeeded."""
    s = g.solution
    what = "" if file else f" {g.objective}: {g.speed:.2f} m/s,"
    print(f"{name}{what} {s.status}, {s.iterations} iterations, {s.seconds:.0f} s, defect "
          f"{s.defect:.1e}", flush=True)  # fmt: skip
    if s.success and file and isinstance(g, TurnSolution):
        save_turn(g, DATA / file)
    elif s.success and file:
        save_transition(g, DATA / file)
    elif s.success:
        save_gait(g, DATA / gait_file(g.om, round(g.speed, 2), g.objective))
    return s.success


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
