"""Optimise the gait cycles the package ships (``make gaits``): the default bodies, as shipped
(with toes) and with one-piece feet (``--no-toes``), at their free speed, the tracking
objective, into ``humanoid/data/gaits`` (the predictive objective's cycles do not ship yet).

Run from the repository: ``python scripts/make_gaits.py [BODY ...]`` (default all of
:data:`BODIES`). Each line printed says what was solved, in how many iterations and seconds,
and the collocation's largest defect.
"""

from __future__ import annotations

import sys

import humanoid as hm
from humanoid.optimal.cycle import DATA, gait_file, save_gait
from humanoid.optimal.gait import optimise_gait

BODIES = {  # name: the shipped body's name, and whether it has toes
    "adult_male": ("adult_male", True),
    "adult_female": ("adult_female", True),
    "adult_male_no_toes": ("adult_male", False),
    "adult_female_no_toes": ("adult_female", False),
}
SHIPPED = {"adult_male": (1.75, 75.0, "male"), "adult_female": (1.62, 62.0, "female")}


def main(names) -> int:
    for name in names or BODIES:
        if name not in BODIES:
            print(f"make_gaits: no body {name!r}; there are {', '.join(BODIES)}", file=sys.stderr)
            return 2
        body, toes = BODIES[name]
        h = hm.load(body)
        if not toes:
            h = hm.load(hm.build_urdf(hm.BodyParameters(*SHIPPED[body], toes=False)))
        for objective in ("tracking",):
            g = optimise_gait(h, None, objective)
            s = g.solution
            print(
                f"{name} {objective}: {g.speed:.2f} m/s, {s.status}, {s.iterations} "
                f"iterations, {s.seconds:.0f} s, defect {s.defect:.1e}",
                flush=True,
            )
            if not s.success:
                return 1
            save_gait(g, DATA / gait_file(g.om, round(g.speed, 2), objective))
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
