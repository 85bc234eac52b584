"""Set-up: a scene and its body -> what a run needs. The body is built once (or handed in),
the scene is checked against it once (frame names, sizes: :func:`check_scene`), and each of
the scene's variants is taken from its registry: the effects, the contacts and the ground
contact's solve, the scene's controller, the quaternion formulation, the constraint backend
and the integrator."""

from __future__ import annotations

from collections.abc import Callable

import numpy as np
import pinocchio as pin

from ..anthropometry import BodyParameters
from ..body import build_urdf
from ..constraints import Baumgarte, JointLock, update_kinematics
from ..constraints.ground import SPECULATIVE_SPEED, ContactSolver, Ground, GroundSettings
from ..constraints.limits import JointRanges
from ..contacts import ContactState
from ..effects import (
    Effect,
    JointDamping,
    JointLimits,
    JointSprings,
    PostureController,
    Push,
    joint_mask,
)
from ..errors import ConfigurationError, HumanoidError, ModelError, SceneError
from ..model import Humanoid, check_configuration, load
from ..scene import Contact, Scene
from .backends import CONSTRAINT_BACKENDS, Reference
from .formulation import FORMULATION
from .integration import INTEGRATION

__all__ = [
    "CONTROLLER_FACTORIES",
    "GROUND_BODIES",
    "JOINT_LIMIT_KINDS",
    "Setup",
    "check_scene",
    "initial_state",
    "load_body",
]

GROUND_TOLERANCE = 1e-6  # [m] a sole point this close to z = 0 touches the ground


def load_body(scene: Scene) -> Humanoid:
    """The scene's body, built: a URDF path or a body's name, or BodyParameters."""
    if isinstance(scene.body, BodyParameters):
        return load(build_urdf(scene.body), ball_joints=scene.ball_joints)
    try:
        return load(scene.body, ball_joints=scene.ball_joints, massless=scene.massless)
    except ModelError as exc:
        raise SceneError(f"{scene.source}: body.urdf: {exc}") from None


def check_scene(scene: Scene, h: Humanoid) -> tuple[np.ndarray, np.ndarray]:
    """Check the scene against its body: the frames it pushes exist, its initial state fits.

    Returns:
        The initial state ``(q0, v0)`` of the scene on that body.

    Raises:
        SceneError: naming the scene file, the key and the reason.
    """
    for i, p in enumerate(scene.effects.pushes):
        if not h.model.existFrame(p.frame):
            frames = sorted(f.name for f in h.model.frames if f.type.name in ("BODY", "OP_FRAME"))
            raise SceneError(
                f"{scene.source}: effects.pushes[{i}].frame: no frame {p.frame!r} in the body; "
                f"frames: {', '.join(frames)}"
            )
    return initial_state(scene, h)


def initial_state(scene: Scene, h: Humanoid) -> tuple[np.ndarray, np.ndarray]:
    """(q0, v0) of a scene on its body: sizes and unit quaternions checked here (NaN and inf
    never get this far: the scene's own validation rejects them)."""
    model = h.model
    ini = scene.initial
    if isinstance(ini.configuration, str):
        q = h.standing_configuration()
    else:
        q = np.array(ini.configuration, dtype=float)
        if q.shape != (model.nq,):
            raise SceneError(f"{scene.source}: initial.configuration: needs nq = {model.nq} "
                             f"numbers, got {q.size}")  # fmt: skip
    q[2] += ini.lift
    v = np.zeros(model.nv)
    v[:6] = ini.base_velocity
    jv = np.asarray(ini.joint_velocity, dtype=float)
    if jv.ndim == 0 or jv.shape == (model.nv - 6,):
        v[6:] = jv
    else:
        raise SceneError(f"{scene.source}: initial.joint_velocity: needs 1 or {model.nv - 6} "
                         f"numbers, got {jv.size}")  # fmt: skip
    try:  # the same check as every state: finite, bounded, unit quaternions (normalised)
        return check_configuration(h, q, v)
    except ConfigurationError as exc:
        raise SceneError(f"{scene.source}: initial: {exc}") from None


class Setup:
    """A scene made ready to run on its body (see the module docstring).

    Attributes:
        scene, h: The scene and its body.
        model, data: The body's model with the scene's gravity, and its data.
        q0, v0: The scene's initial state on the body.
        effects: The scene's effects (a list: damping, springs, joint limits, pushes).
        contacts: A :class:`~humanoid.contacts.ContactState` per scheduled contact.
        ranges: The joint ranges as constraints of the ground's solve, or None.
        ground: The ground contact's velocity-level solve, or None.
        controller: The scene's controller, or None.
        baumgarte: The constraints' stabilisation.
        formulation, backend, integrator: The variants' implementations.
    """

    def __init__(self, scene: Scene, humanoid: Humanoid | None = None) -> None:
        self.scene = scene
        self.h = h = humanoid or load_body(scene)
        self.model = h.model.copy()
        e = scene.effects
        self.gravity = np.array(e.gravity, dtype=float)
        self.has_gravity = bool(np.any(self.gravity))
        self.model.gravity = pin.Motion(self.gravity, np.zeros(3))
        self.data = self.model.createData()
        self.mask = joint_mask(self.model)
        self.q0, self.v0 = check_scene(scene, h)  # frames, sizes, finite numbers
        limit_effect, self.ranges = None, None
        if e.joint_limits is not None:
            limit_effect, self.ranges = JOINT_LIMIT_KINDS[e.joint_limits.kind](self)
        self.effects = scene_effects(self, limit_effect)
        self.contacts = [ContactState(h, c) for c in e.contacts]
        self.ground = ground_solver(self) if e.ground is not None else None
        self.controller = CONTROLLER_FACTORIES[scene.controller.kind](self)
        tc = scene.stabilisation.baumgarte * scene.dt
        self.baumgarte = Baumgarte.from_time_constant(tc) if tc > 0 else Baumgarte()
        self.formulation = FORMULATION[scene.stabilisation.quaternions](self.model)
        self.integrator = INTEGRATION[scene.integrator](scene)
        backend = CONSTRAINT_BACKENDS[scene.stabilisation.backend]
        self.backend = backend if backend.supports(self) else Reference
        self.gimbal = gimbal_triplets(h)

    def legs(self) -> dict:
        """Each side's leg: the joints from its hip down to its sole (the subtree of the root's
        child on the way to the sole), or {} for a body without two soles."""
        model, out = self.model, {}
        for side in ("left", "right"):
            try:
                j = model.frames[self.h.sole_id(side)].parentJoint
            except HumanoidError:
                return {}
            while j > 0 and model.parents[j] > 1:
                j = model.parents[j]
            if j <= 1:
                return {}
            out[side] = np.array(model.subtrees[j], dtype=int)
        return out


def scene_effects(setup: Setup, limits) -> list:
    """The scene's effects in the order their forces add up: damping, springs, the joint
    limits' springs, pushes."""
    model, e = setup.model, setup.scene.effects
    effects: list[Effect] = []
    if e.damping > 0:
        effects.append(JointDamping(model, e.damping))
    if e.springs > 0:
        effects.append(JointSprings(model, e.springs, setup.q0))
    if limits is not None:
        effects.append(limits)
    for p in e.pushes:
        effects.append(Push(model.getFrameId(p.frame), p.force, p.start, p.duration, p.torque))
    return effects


def _spring_limits(setup: Setup) -> tuple[JointLimits, None]:
    spec = setup.scene.effects.joint_limits
    assert spec is not None  # chosen for a scene with joint limits
    return JointLimits(setup.h, spec.stiffness, spec.damping), None


# joint-limit kind -> (setup -> (its effect or None, its ranges as constraints or None)); the
# names are humanoid.variants.JOINT_LIMITS'
JOINT_LIMIT_KINDS: dict[str, Callable] = {
    "spring": _spring_limits,
    "constraint": lambda setup: (None, JointRanges(setup.h)),
}


def _feet_geometries(setup: Setup, geometry) -> list[int]:
    """A foot and what hangs below it (its toes)."""
    model, h = setup.model, setup.h
    roots = [model.frames[h.frame_id(f)].parentJoint for f in h.feet]
    feet = {j for root in roots for j in model.subtrees[root]}
    return [i for i, g in enumerate(geometry.geometryObjects) if g.parentJoint in feet]


def _link_geometries(setup: Setup, geometry, names) -> list[int]:
    model, joints = setup.model, {}
    for name in names:
        if not model.existFrame(name):
            links = sorted(f.name for f in model.frames if f.type == pin.FrameType.BODY)
            raise SceneError(f"{setup.scene.source}: effects.ground.bodies: no link {name!r}; "
                             f"links: {', '.join(links)}")  # fmt: skip
        joints[model.frames[model.getFrameId(name)].parentJoint] = name
    return [i for i, g in enumerate(geometry.geometryObjects) if g.parentJoint in joints]


# effects.ground.bodies -> (setup, geometry -> the geometries on the ground); else link names
GROUND_BODIES: dict[str, Callable] = {
    "all": lambda setup, geometry: list(range(geometry.ngeoms)),
    "feet": _feet_geometries,
}


def ground_solver(setup: Setup) -> ContactSolver:
    """The ground contact of the bodies the scene names, with the joint ranges as
    constraints if it asks for them."""
    h, spec = setup.h, setup.scene.effects.ground
    assert spec is not None  # built for a scene with a ground
    geometry = h.collision_model if h.collision_model.ngeoms else h.visual_model
    if isinstance(spec.bodies, str):
        chosen = GROUND_BODIES[spec.bodies](setup, geometry)
    else:
        chosen = _link_geometries(setup, geometry, spec.bodies)
    # the candidates reach SPECULATIVE_SPEED times the step (at the default 1 ms, the margin)
    margin = max(spec.margin, SPECULATIVE_SPEED * setup.scene.dt)
    settings = GroundSettings(mu=spec.mu, margin=margin, tolerance=spec.tolerance,
                              solver=spec.solver)  # fmt: skip
    ground = Ground(setup.model, geometry, chosen, settings) if chosen else None
    return ContactSolver(setup.model, ground, setup.ranges, settings)


def posture_controller(setup: Setup) -> PostureController:
    """The scene's posture hold, tuned on the body through the contacts that attach at t = 0."""
    ctl = setup.scene.controller
    J = initial_contact_jacobian(setup)
    return PostureController(setup.model, setup.q0, ctl.kp, ctl.kd, ctl.frequency,
                             ctl.damping_ratio, J)  # fmt: skip


# controller.kind -> (setup -> the scene's controller); the names are
# humanoid.variants.CONTROLLERS'
CONTROLLER_FACTORIES: dict[str, Callable] = {
    "none": lambda setup: None,
    "posture": posture_controller,
}


def initial_contact_jacobian(setup: Setup) -> np.ndarray:
    """Jacobian at q0 of the contacts that attach at t = 0 (scheduled, on the ground).
    On the ground contact (no scheduled contacts), the feet standing on the floor count
    as welded."""
    model, data = setup.model, setup.data
    update_kinematics(model, data, setup.q0, np.zeros(model.nv))
    contacts = setup.contacts
    if not contacts and setup.ground is not None:
        contacts = [ContactState(setup.h, Contact(side)) for side in ("left", "right")]
    rows = []
    for c in contacts:
        if c.spec.start == 0.0 and c.lowest(data) <= GROUND_TOLERANCE:
            c.attach(data)
            # the feet's own rows (a weld's locked toes) left out: the hold's gains see the
            # toes free to turn (with them, its toes' gain was the pseudo-inverse of a
            # near-zero inertia, and the pushed balance scene's toes chattered at 34 rad/s)
            rows += [k.jacobian(model, data) for k in c.constraints
                     if not isinstance(k, JointLock)]  # fmt: skip
            c.release()
            c.ever_attached = False
    return np.vstack(rows) if rows else np.zeros((0, model.nv))


def gimbal_triplets(h: Humanoid) -> list[tuple[str, int]]:
    """(name, q index of the middle hinge) of every hinge triplet of an Euler-mode model."""
    if h.ball_joints != "euler":
        return []
    from ..fusion import ball_name, find_triplets

    model = h.model
    return [
        (ball_name(model, t), model.joints[t[1]].idx_q)
        for t in find_triplets(model, (h.visual_model, h.collision_model))
    ]
