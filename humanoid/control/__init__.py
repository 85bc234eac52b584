"""Whole-body control: tasks on the generalised acceleration, contacts with friction pyramids
and ramped force bounds, and the one QP that every controller of the toolkit builds (the
welded walk, the person's walk, the human gait, motion tracking)."""

from .qp import ContactQP, WarmQP, contact_qp, dynamics_terms, whole_body_qp
from .tasks import (
    CentreOfMassTask,
    ForceTask,
    FrameTask,
    MomentumTask,
    OrientationTask,
    PostureTask,
    Task,
    TaskStack,
)

__all__ = [
    "CentreOfMassTask",
    "ContactQP",
    "ForceTask",
    "FrameTask",
    "MomentumTask",
    "OrientationTask",
    "PostureTask",
    "Task",
    "TaskStack",
    "WarmQP",
    "contact_qp",
    "dynamics_terms",
    "whole_body_qp",
]
