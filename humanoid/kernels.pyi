# The compiled kernels (humanoid/kernels.c); every array argument is a C-contiguous buffer of
# float64 (points, rotations) or int64 (indices).
from typing import Any

def ground_plan(
    nj: int,
    nq: int,
    nv: int,
    nc: int,
    nshared: int,
    ndirs: int,
    max_points: int,
    depth_weight: float,
    shared: float,
    *arrays: Any,
) -> object: ...
def ground_select(plan: object, q: Any, margin: float) -> int: ...
def ground_write(plan: object, points: Any, joints: Any, local: Any, J: Any, ids: Any) -> None: ...
def placements(plan: object, q: Any, R: Any, t: Any) -> None: ...
def range_plan(nv: int, nh: int, nb: int, lock: float, *arrays: Any) -> object: ...
def range_rows(
    plan: object, q: Any, margin: float, hint: Any, has_hint: bool, r: Any, J: Any, ids: Any
) -> int: ...
def contact_solve(
    J: Any,
    Minv: Any,
    v_free: Any,
    gap: Any,
    nc: int,
    mu: float,
    tol: float,
    rho: float,
    max_iter: int,
    mem: int,
    screen: float,
    lam: Any,
    v: Any,
) -> tuple[int, bool, float, int, bool]: ...
def tree_dynamics(
    plan: object,
    n: int,
    inertia: Any,
    gravity: Any,
    q: Any,
    v: Any,
    a: Any,
    R: Any,
    t: Any,
    w: Any,
    m: Any,
    f: Any,
    tau: Any,
) -> None: ...
def constraint_rows(
    plan: object,
    q: Any,
    v: Any,
    ints: Any,
    reals: Any,
    alpha: float,
    beta: float,
    J: Any,
    gamma: Any,
) -> int: ...
def held_torques(
    plan: object,
    inertia: Any,
    gravity: Any,
    q: Any,
    v: Any,
    dv: Any,
    ints: Any,
    reals: Any,
    tau: Any,
) -> int: ...
