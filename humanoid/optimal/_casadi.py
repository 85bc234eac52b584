"""casadi, imported once with the reasons it may not be there."""

import sys

from ..errors import ExtraConflict, MissingExtra

if "opensim" in sys.modules:
    raise ExtraConflict(
        "humanoid.optimal needs casadi, which cannot share a process with opensim (OpenSim's "
        "wheel bundles its own casadi libraries): use them in separate processes"
    )
try:
    import casadi as ca
except ImportError as exc:  # pragma: no cover - the test environment has casadi
    raise MissingExtra(
        "humanoid.optimal needs casadi: pip install 'humanoid-toolkit[optimal]' (or casadi)"
    ) from exc

__all__ = ["ca"]
