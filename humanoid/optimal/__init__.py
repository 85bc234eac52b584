"""Optimal control of the body: its dynamics as casadi expressions (:mod:`.dynamics`), the body
in vector-space coordinates (:mod:`.coordinates`), direct collocation through its rigid contact
dynamics (:mod:`.problem`) and a person's gait cycle optimised with it (:mod:`.gait`), its
start from standing and stop to standing (:mod:`.transitions`) and its turn along a circle
(:mod:`.turn`).

:mod:`.coordinates` and :mod:`.cycle` (a solved cycle as data, its storage) need numpy and
Pinocchio only: a walk reads a shipped or cached cycle without casadi. The rest needs casadi
(``pip install 'humanoid-toolkit[optimal]'``); ``import humanoid`` imports none of it.
"""

__all__ = ["Kinematics", "SymbolicModel"]


def __getattr__(name):
    if name in __all__:
        from . import dynamics

        return getattr(dynamics, name)
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
