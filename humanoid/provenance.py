"""Where and when a number was measured: the machine, the date and the versions that matter
(benchmarks and study reports print it beside their numbers)."""

from __future__ import annotations

import numpy as np
import pinocchio as pin

__all__ = ["machine"]


def machine() -> str:
    """Where and when a benchmark ran: CPU, cores, the date, and the versions that matter."""
    import datetime
    import os
    import platform

    cpu = platform.processor() or platform.machine()
    try:
        with open("/proc/cpuinfo") as fh:
            cpu = next(
                line.split(":", 1)[1].strip() for line in fh if line.startswith("model name")
            )
    except (OSError, StopIteration):
        pass
    from . import __version__

    date = datetime.datetime.now(datetime.UTC).strftime("%Y-%m-%d %H:%M UTC")
    return (f"{cpu}, {os.cpu_count()} cores, {platform.system()}; {date}; humanoid "
            f"{__version__}, Pinocchio {pin.__version__}, NumPy {np.__version__}, Python "
            f"{platform.python_version()}; {threads()}")  # fmt: skip


def threads() -> str:
    """The thread pools a simulation runs with (one: :meth:`Simulation.run
    <humanoid.simulation.Simulation.run>` limits them) and the environment's own."""
    from threadpoolctl import threadpool_info

    pools = ", ".join(f"{p['internal_api']} {p['num_threads']}" for p in threadpool_info())
    return f"each run on 1 thread (the environment's pools: {pools or 'none loaded'})"
