"""Optimal control of the body: its dynamics as casadi expressions (:mod:`.dynamics`), the body
in vector-space coordinates (:mod:`.coordinates`), direct collocation through its rigid contact
dynamics (:mod:`.problem`) and a person's gait cycle optimised with it (:mod:`.gait`).

Needs casadi (``pip install 'humanoid-toolkit[optimal]'``); ``import humanoid`` does not import
this package.
"""

import sys

if "opensim" in sys.modules:
    raise ImportError(
        "humanoid.optimal needs casadi, which cannot share a process with opensim (OpenSim's "
        "wheel bundles its own casadi libraries): use them in separate processes"
    )
try:
    import casadi  # noqa: F401
except ImportError as exc:  # pragma: no cover - the test environment has casadi
    raise ImportError(
        "humanoid.optimal needs casadi: pip install 'humanoid-toolkit[optimal]' (or casadi)"
    ) from exc

from .dynamics import Kinematics, SymbolicModel

__all__ = ["Kinematics", "SymbolicModel"]
