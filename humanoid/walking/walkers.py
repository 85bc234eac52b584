"""The walks on the rigid ground that a gait names (``humanoid walk --gait person|human``):
the cycle each follows and a function that walks it (:func:`ground_walker`), the body's
optimised gait cycle, stored or optimised now (:func:`person_gait`), and the rules of how many
steps a walk from standing or a pushed walk needs."""

from __future__ import annotations

from ..errors import MissingExtra

__all__ = [
    "FROM_STANDING_STEPS",
    "GROUND_GAITS",
    "MAX_PUSH",
    "PUSHED_STEPS",
    "from_standing_strides",
    "ground_walker",
    "person_gait",
]

GROUND_GAITS = ("person", "human")  # (the third gait, "welded", is humanoid.walking.run's)
# the fewest steps of a walk from standing: the person's two steps to start, two to stop and a
# whole stride between; the fitted cycle's last step brings the feet together
FROM_STANDING_STEPS = {"person": 7, "human": 3}
PUSHED_STEPS = 8  # a push acts at a mid-stance of the third stride
MAX_PUSH = 2.0  # [body weights] the largest push a walk is given


def from_standing_strides(steps: int) -> int:
    """The whole strides between a person's two steps to start and two to stop (at least
    one) in a walk of ``steps`` steps from standing."""
    return max(1, (steps - 5) // 2)


def person_gait(h, speed=None, quiet: bool = False):
    """The body's optimised gait cycle (tracking objective) at ``speed`` (default its free
    speed): shipped with the package or in the user's cache, else optimised now (casadi) and
    cached, saying so.

    Raises:
        MissingExtra: no cycle is stored, and casadi (the optimal-control extra) is missing.
    """
    from ..optimal.cycle import cache_dir, default_speed, stored_gait

    gait = stored_gait(h, speed)
    if gait is not None:
        return gait
    speed = round(default_speed(h) if speed is None else speed, 2)
    try:
        from ..optimal.gait import gait_cycle
    except ImportError as exc:
        raise MissingExtra(
            f"no optimised gait cycle of {h.source} at {speed:.2f} m/s is shipped or cached, "
            f"and optimising one needs the optimal-control extra ({exc})"
        ) from exc
    if not quiet:
        print(f"optimising the gait cycle of {h.source} at {speed:.2f} m/s (once, a few "
              f"minutes; cached in {cache_dir()})", flush=True)  # fmt: skip
    return gait_cycle(h, speed)


def ground_walker(h, gait: str, speed=None, *, dt: float, mu: float, quiet: bool = False,
                  control_dt: float | None = None):  # fmt: skip
    """The cycle a ``gait`` (``"person"`` or ``"human"``) walk of ``h`` follows at ``speed``
    [m/s] (default its own) and ``walk(steps, pushes, **kw)`` that walks it (``kw``: quiet,
    record_rate, from_standing, radius). ``control_dt``: the person's QP period [s]
    (:func:`~humanoid.walking.person.walk_cycle`; the default if None)."""
    if gait == "human":
        from .gait import walk_on_ground
        from .reference import fit_cycle

        cycle = fit_cycle(h, speed)

        def walk_human(steps, pushes, **kw):
            return walk_on_ground(h, steps=steps, cycle=cycle, dt=dt, mu=mu, pushes=pushes,
                                  **kw)  # fmt: skip

        return cycle, walk_human
    from .person import walk_cycle, walk_from_standing

    cycle = person_gait(h, speed, quiet=quiet)

    def walk(steps, pushes, from_standing=False, radius=None, **kw):
        kw.setdefault("control_dt", control_dt)
        if from_standing:  # two steps to start, two to stop, whole strides between
            strides = from_standing_strides(steps)
            return walk_from_standing(h, cycle, strides, dt=dt, mu=mu, **kw)
        return walk_cycle(h, cycle, steps, dt=dt, mu=mu, pushes=pushes, radius=radius, **kw)

    return cycle, walk
