"""Walking with foot contacts: a gait plan, a CoM trajectory, a whole-body torque controller,
and the walk as a forward simulation (:func:`walk`)."""

from .controller import ControllerGains, WalkingController
from .plan import FootstepPlan, GaitParameters
from .preview import PreviewController, com_trajectory
from .report import format_summary, plot_walk
from .run import WalkResult, crouch, walk

__all__ = [
    "ControllerGains",
    "FootstepPlan",
    "GaitParameters",
    "PreviewController",
    "WalkResult",
    "WalkingController",
    "com_trajectory",
    "crouch",
    "format_summary",
    "plot_walk",
    "walk",
]
