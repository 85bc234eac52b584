"""``humanoid bench`` (the benchmarks) and ``humanoid sweep`` (a study, on Dask)."""

from __future__ import annotations

__all__ = ["add_bench", "add_sweep", "run_bench", "run_sweep"]

# each benchmark: its module in humanoid.bench and the function that runs it
BENCHMARKS = {
    "step": ("step", "run_step_benchmark"),
    "walk": ("walk", "run_walk_benchmark"),
    "scaling": ("scaling", "run_scaling_benchmark"),
    "accuracy": ("accuracy", "run_accuracy_benchmark"),
    "motion": ("motion", "run_motion_benchmark"),
    "track": ("track", "run_track_benchmark"),
}


def add_bench(command) -> None:
    """``humanoid bench``: the benchmarks."""
    bench = command(
        "bench",
        help="benchmarks: step cost, walking cost, work-precision "
        "(accuracy), motion against OpenSim, tracking against real time",
    )
    bench.add_argument(
        "kind",
        choices=tuple(BENCHMARKS),
        help="step: one step against Pinocchio (and MuJoCo on the ground); walk: a simulated "
        "second of walking, its parts and the bare plant; scaling: cost against nv and the "
        "contacts; motion: inverse dynamics and "
        "kinematics against OpenSim 4; track: tracking recorded walks against real time",
    )
    bench.add_argument("--quick", action="store_true", help="fewer repetitions")
    bench.add_argument("-o", "--output", default="results/bench", help="folder for the CSV")


def add_sweep(command) -> None:
    """``humanoid sweep``: a study's runs (its arguments: :mod:`humanoid.study.commands`)."""
    from ..study.commands import add_sweep_parser

    add_sweep_parser(command)


def run_bench(args) -> int:
    import importlib

    from ..provenance import machine

    module, function = BENCHMARKS[args.kind]
    run = getattr(importlib.import_module(f"humanoid.bench.{module}"), function)
    print(f"machine      {machine()}")  # (the threads each timing ran with among it)
    return run(quick=args.quick, out=args.output)


def run_sweep(args) -> int:
    from ..study.commands import run_sweep

    return run_sweep(args)
