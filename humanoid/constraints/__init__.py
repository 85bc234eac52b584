"""The project's constraint layer: constraints, the KKT solve, stabilisation."""

from .base import Constraint, update_kinematics
from .foot import PointContact, Weld
from .solve import Baumgarte, ConstrainedAcceleration, constrained_dynamics, solve_kkt

__all__ = [
    "Baumgarte",
    "ConstrainedAcceleration",
    "Constraint",
    "PointContact",
    "Weld",
    "constrained_dynamics",
    "solve_kkt",
    "update_kinematics",
]
