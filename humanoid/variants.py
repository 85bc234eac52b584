"""The variants a scene, a walk and the command line choose from, one registry each.

A registry maps every valid name to what it means. Scenes validate against it, the CLI takes
its choices and help from it, and ``humanoid variants`` prints them all, so a variant added to
a registry is offered everywhere and an unknown name is refused everywhere with the same list.
"""

from __future__ import annotations

from collections.abc import Iterator, Mapping

__all__ = [
    "BACKENDS",
    "BALL_JOINTS",
    "CONTACT_KINDS",
    "CONTACT_SOLVERS",
    "CONTROLLERS",
    "FORMULATIONS",
    "INTEGRATORS",
    "JOINT_LIMITS",
    "MASSLESS",
    "REGISTRIES",
    "Registry",
]


class Registry(Mapping[str, str]):
    """Names of one kind of variant and what each means (a read-only mapping).

    Args:
        what: What the names are ("integrator", "contact kind"...).
        key: Where a scene sets it (``stabilisation.backend``), or "" if a scene does not.
        entries: name -> one line on what it is.
    """

    def __init__(self, what: str, key: str, entries: dict[str, str]) -> None:
        self.what, self.key = what, key
        self._entries = dict(entries)

    def __getitem__(self, name: str) -> str:
        return self._entries[name]

    def __iter__(self) -> Iterator[str]:
        return iter(self._entries)

    def __len__(self) -> int:
        return len(self._entries)

    def choices(self) -> str:
        """The names as a sentence ends: "a, b or c"."""
        names = list(self._entries)
        return names[0] if len(names) == 1 else f"{', '.join(names[:-1])} or {names[-1]}"

    def refusal(self, value) -> str | None:
        """None if ``value`` is one of the names, else the reason it is not."""
        if isinstance(value, str) and value in self._entries:
            return None
        return f"unknown {self.what} {value!r}: must be {self.choices()}"


INTEGRATORS = Registry("integrator", "integrator", {
    "euler": "explicit Euler, order 1 (energy grows)",
    "semi_implicit_euler": "symplectic Euler, order 1, bounded energy error; the only one with "
                           "ground contact (impulses at the velocity level)",
    "rk4": "classical Runge-Kutta on the Lie group (Munthe-Kaas), order 4",
    "adaptive": "Dormand-Prince 5(4) with error control (rtol, atol) inside every dt",
})  # fmt: skip
FORMULATIONS = Registry("quaternion formulation", "stabilisation.quaternions", {
    "lie": "quaternions on their Lie group (Pinocchio's integrate): unit norm by construction",
    "coordinates": "the seeds' coordinate formulation: the quaternion norm as a constraint",
})  # fmt: skip
BACKENDS = Registry("constraint backend", "stabilisation.backend", {
    "native": "the project's constraints solved in Pinocchio's C++ (their rigid-constraint "
              "twins through constraintDynamics; J and drift through forwardDynamics otherwise)",
    "reference": "the project's KKT solve in NumPy (Delassus matrix, Cholesky or eigen "
                 "cut-off): readable, the cross-check",
})  # fmt: skip
CONTACT_KINDS = Registry("contact kind", "effects.contacts[].kind", {
    "weld": "the sole frame welded in 6D where it lands",
    "points": "the four sole corners pinned in 3D where they land",
})  # fmt: skip
CONTACT_SOLVERS = Registry("contact solver", "effects.ground.solver", {
    "kernel": "the project's compiled ADMM on the ground's and the ranges' conic problem, "
              "warm-started from the last step (the default)",
    "admm": "Pinocchio's ADMM on the same problem, from zero at every step",
    "pgs": "Pinocchio's projected Gauss-Seidel on the same problem (slower, measured)",
})  # fmt: skip
JOINT_LIMITS = Registry("joint-limit kind", "effects.joint_limits.kind", {
    "spring": "a stiff spring-damper beyond each limit (any integrator)",
    "constraint": "unilateral constraints in the ground contact's solve: ranges that hold",
})  # fmt: skip
CONTROLLERS = Registry("controller", "controller.kind", {
    "none": "no controller: the body is limp",
    "posture": "joint PD holding the initial posture (static feed-forward through the contacts)",
})  # fmt: skip
BALL_JOINTS = Registry("ball-joint mode", "body.ball_joints", {
    "quaternion": "hinge triplets fused into spherical joints (no gimbal lock)",
    "euler": "the URDF's hinges as written (gimbal lock at +-90 degrees)",
})  # fmt: skip
MASSLESS = Registry("massless-joint policy", "body.massless", {
    "error": "refuse a model with joints that move no mass",
    "merge": "lock joints that move no mass into their parents",
})  # fmt: skip

REGISTRIES = (INTEGRATORS, FORMULATIONS, BACKENDS, CONTACT_KINDS, CONTACT_SOLVERS, JOINT_LIMITS,
              CONTROLLERS, BALL_JOINTS, MASSLESS)  # fmt: skip
