"""The project's constraint layer: constraints, the KKT solve, stabilisation."""

from .base import Constraint, update_kinematics
from .foot import JointLock, PointContact, Weld, foot_hinges
from .solve import Baumgarte, ConstrainedAcceleration, constrained_dynamics, solve_kkt

__all__ = [
    "Baumgarte",
    "ConstrainedAcceleration",
    "Constraint",
    "JointLock",
    "PointContact",
    "Weld",
    "constrained_dynamics",
    "foot_hinges",
    "solve_kkt",
    "update_kinematics",
]
