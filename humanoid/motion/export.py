"""A run (a simulation's trajectory) written as OpenSim reads it: coordinates and ground loads."""

from __future__ import annotations

from pathlib import Path

from ..errors import TrajectoryError
from .coordinates import coordinates_table
from .loads import Load, write_loads
from .storage import write_storage

__all__ = ["write_opensim"]


def write_opensim(h, run, path: str | Path, cmap="rajagopal") -> list[Path]:
    """Write ``run``'s configurations as an OpenSim coordinate file (``path``, degrees, the map's
    names) and, if it had ground contact, each foot's ground force as an external loads file
    (``<stem>_grf.mot``, and its ExternalLoads ``.xml``: OpenSim's inverse dynamics reads them
    as they are). Returns the files written."""
    path = Path(path)
    if run.q.shape[1] != h.nq:
        raise TrajectoryError(f"the run's configurations are not {h.source}'s ({h.nq} entries)")
    written = [write_storage(path, coordinates_table(h, run.t, run.q, cmap))]
    sides = [s for s in ("left", "right") if f"ground_{s}" in run.forces]
    if sides:
        loads = [Load.from_wrench(s, run.t, run.forces[f"ground_{s}"]) for s in sides]
        grf = write_loads(path.with_name(f"{path.stem}_grf.mot"), loads, name=f"{path.stem} loads")
        written += [grf, grf.with_suffix(".xml")]
    return written
