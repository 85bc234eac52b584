"""Walking with foot contacts: a gait plan, a CoM trajectory, a whole-body torque controller."""

from .plan import FootstepPlan, GaitParameters
from .preview import PreviewController, com_trajectory

__all__ = ["FootstepPlan", "GaitParameters", "PreviewController", "com_trajectory"]
