#!/usr/bin/env python3
"""Regenerate the shipped bodies (humanoid/data/bodies/) from the current body builder.

The shipped bodies are median adults, close to de Leva's (1996) reference subjects
(male 1.741 m / 73.0 kg, female 1.735 m / 61.9 kg) and to the usual "50th percentile"
adult of biomechanics texts: male 1.75 m / 75 kg, female 1.62 m / 62 kg.

Usage: python scripts/make_models.py [--out humanoid/data/bodies]
"""

from __future__ import annotations

import argparse
from pathlib import Path

from humanoid import BodyParameters, write_urdf
from humanoid.data import BODIES

SHIPPED = {
    "adult_male.urdf": BodyParameters(height=1.75, mass=75.0, sex="male"),
    "adult_female.urdf": BodyParameters(height=1.62, mass=62.0, sex="female"),
}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", default=str(BODIES))
    args = parser.parse_args()
    for name, params in SHIPPED.items():
        path = write_urdf(params, Path(args.out) / name)
        print(f"wrote {path}")


if __name__ == "__main__":
    main()
