"""The integrators a scene names (:data:`humanoid.variants.INTEGRATORS`), each an ``advance``
of one step of dt: :data:`INTEGRATION` maps the name to its implementation."""

from __future__ import annotations

from collections.abc import Callable

from ..integrators import STEPPERS, DormandPrince, semi_implicit_euler
from ..scene import Scene

__all__ = ["INTEGRATION", "Adaptive", "FixedStep"]


class FixedStep:
    """One step of a fixed-step scheme (:data:`humanoid.integrators.STEPPERS`).

    ``inline_euler``: the scheme is semi-implicit Euler, which the plant inlines on the Lie
    group (one evaluation per step, the hot path).
    """

    fixed = True

    def __init__(self, stepper: Callable, inline_euler: bool = False) -> None:
        self.stepper, self.inline_euler = stepper, inline_euler

    def advance(self, space, f, t: float, q, v, dt: float):
        return self.stepper(space, f, t, q, v, dt)

    def metadata(self) -> dict:
        return {}


class Adaptive:
    """Dormand-Prince 5(4) with error control inside every dt (its own internal steps)."""

    fixed = False
    inline_euler = False

    def __init__(self, scene: Scene) -> None:
        self.method = DormandPrince(scene.rtol, scene.atol, max_step=scene.dt)

    def advance(self, space, f, t: float, q, v, dt: float):
        return self.method.advance(space, f, t, q, v, t + dt)

    def metadata(self) -> dict:
        return {"adaptive": vars(self.method.stats)}


def _fixed(stepper: Callable) -> Callable[[Scene], FixedStep]:
    return lambda scene: FixedStep(stepper, inline_euler=stepper is semi_implicit_euler)


# name -> (scene -> its implementation); the names are humanoid.variants.INTEGRATORS'
INTEGRATION: dict[str, Callable[[Scene], FixedStep | Adaptive]] = {
    **{name: _fixed(stepper) for name, stepper in STEPPERS.items()},
    "adaptive": Adaptive,
}
