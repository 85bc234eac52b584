"""Load any humanoid URDF into Pinocchio with a free-flyer root: :func:`load`.

The package, by concept: :mod:`~humanoid.model.loading` (the loader),
:mod:`~humanoid.model.checks` (the URDF's checks), :mod:`~humanoid.model.feet` (foot
discovery, sole frames and contact points), :mod:`~humanoid.model.reduction` (joints locked or
merged), and :mod:`~humanoid.model.humanoid`: the loaded :class:`Humanoid`.

What loading does, in order:

1. Reads the URDF (a path, a string of XML, a shipped body's name such as ``"adult_male"``,
   or an example-robot-data robot's name such as ``"talos"``) and checks it before Pinocchio
   sees it: well-formed XML; one tree of links (no cycle, no link with two parents, no joint
   from a link to itself); known joint types; every origin, axis and size three finite numbers
   separated by spaces; finite non-negative masses and positive semi-definite inertias; mesh
   files that exist. After building, each joint's inertia must equal the sum of its links'
   declared inertias (urdfdom drops what it cannot read without a word). Each problem is a
   :class:`ModelError` naming the file and the element.
2. Builds the Pinocchio model with a ``JointModelFreeFlyer`` root at the URDF's root link (the
   pelvis of a human), and its visual and collision geometry.
3. Finds the feet by name (``sole`` before ``foot`` before ``ankle``, with ``left``/``l`` and
   ``right``/``r`` tokens; a toes segment's frames last) unless the caller names them.
4. Turns a model whose URDF is not Z-up (example-robot-data's human is Y-up, ISB) so that it
   stands along +Z: the free-flyer's joint placement gets the fixed rotation.
5. With ``ball_joints="quaternion"``, fuses hinge triplets into spherical joints
   (:mod:`humanoid.fusion`).
6. Adds, where the model has none, a ``{side}_sole`` frame at the centre of each sole and four
   sole contact points ``{side}_heel_inner|heel_outer|toe_inner|toe_outer``, from the
   bounding box of the foot's geometry (collision geometry first, visual otherwise).
7. Reads the named postures of an SRDF (its ``group_state`` s: example-robot-data's own SRDF
   for its robots, such as Talos's ``half_sitting``, or one the caller gives) into
   :attr:`Humanoid.postures`; :meth:`Humanoid.reference_configuration` stands the body in one.
"""

from .checks import JOINT_TYPES, LINK_TAGS, URDF_MAX_BYTES, UnknownTagWarning
from .feet import CORNERS, FOOT_WORDS
from .humanoid import (
    OTHER_SIDE,
    QUATERNION_TOLERANCE,
    SIDES,
    Humanoid,
    check_configuration,
    child_link,
    quaternion_rows,
)
from .loading import (
    example_robot_names,
    example_robot_path,
    example_robot_srdf,
    load,
    load_example,
    load_recipe,
    lock_foot_hinges,
)
from .reduction import MASSLESS_TOLERANCE, restrict_configurations

__all__ = [
    "CORNERS",
    "FOOT_WORDS",
    "JOINT_TYPES",
    "LINK_TAGS",
    "MASSLESS_TOLERANCE",
    "QUATERNION_TOLERANCE",
    "OTHER_SIDE",
    "SIDES",
    "URDF_MAX_BYTES",
    "Humanoid",
    "UnknownTagWarning",
    "check_configuration",
    "child_link",
    "example_robot_names",
    "example_robot_path",
    "example_robot_srdf",
    "load",
    "load_example",
    "load_recipe",
    "lock_foot_hinges",
    "quaternion_rows",
    "restrict_configurations",
]
