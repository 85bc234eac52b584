"""humanoid: physics-based models of the human body on Pinocchio.

``import humanoid`` loads the body builder, the model loader and the equations of motion; it
starts no server and imports no viewer.
"""

from .anthropometry import BodyParameters, Segment, body_dimensions, segments
from .body import build_urdf, write_urdf
from .dynamics import (
    bias_forces,
    centre_of_mass,
    centroidal_momentum,
    gravity_forces,
    kinetic_energy,
    mass_matrix,
    potential_energy,
    projected_newton_euler,
)
from .errors import (
    BodyParameterError,
    ConfigurationError,
    DivergenceError,
    HumanoidError,
    ModelError,
    SceneError,
    StudyError,
    TrajectoryError,
)
from .model import Humanoid, example_robot_names, load, load_example
from .scene import Scene
from .simulation import Trajectory, simulate

__version__ = "0.1.0"

__all__ = [
    "BodyParameterError",
    "BodyParameters",
    "ConfigurationError",
    "DivergenceError",
    "Humanoid",
    "HumanoidError",
    "ModelError",
    "Scene",
    "SceneError",
    "Segment",
    "StudyError",
    "Trajectory",
    "TrajectoryError",
    "bias_forces",
    "body_dimensions",
    "build_urdf",
    "centre_of_mass",
    "centroidal_momentum",
    "example_robot_names",
    "gravity_forces",
    "kinetic_energy",
    "load",
    "load_example",
    "mass_matrix",
    "potential_energy",
    "projected_newton_euler",
    "segments",
    "simulate",
    "write_urdf",
]
