"""Small dense linear algebra for the per-step paths, where NumPy's general wrappers cost more
than the arithmetic: ``np.cross`` on a few vectors (13 us), ``np.linalg.solve`` on a 20 x 20
system (6 us, LAPACK's Cholesky 2 us)."""

from __future__ import annotations

import sys
from collections.abc import Iterator
from contextlib import contextmanager

import numpy as np

__all__ = ["cholesky_lapack", "cross", "one_thread", "spd_solve"]


def cross(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """a x b over the last axis (3) of arrays that broadcast, e.g. (n, 3) by (n, 3) or (3,).
    Two vectors are crossed in Python floats (the same products and differences)."""
    if a.ndim == 1 and b.ndim == 1:
        x0, x1, x2 = a.tolist()
        y0, y1, y2 = b.tolist()
        return np.array([x1 * y2 - x2 * y1, x2 * y0 - x0 * y2, x0 * y1 - x1 * y0])
    a0, a1, a2 = a[..., 0], a[..., 1], a[..., 2]
    b0, b1, b2 = b[..., 0], b[..., 1], b[..., 2]
    return np.stack([a1 * b2 - a2 * b1, a2 * b0 - a0 * b2, a0 * b1 - a1 * b0], axis=-1)


@contextmanager
def one_thread() -> Iterator[None]:
    """A context in which every BLAS, LAPACK and OpenMP pool runs one thread (threadpoolctl):
    on a body's 39 x 39 matrices threads only cost (the balance scene's step took 2.3 times
    longer with two; a run of implicit steps used 4.3 times the CPU). Nested, it is free; at
    the outermost it sets each pool and puts it back (about 10 us: the pools are found once,
    and again whenever a module was imported since, as a pool loaded after the limit is set is
    not limited; scipy.linalg, whose own BLAS the solves load on first use, is loaded first)."""
    global _depth
    if _depth:
        yield
        return
    pools = _pools()
    before = [pool.get_num_threads() for pool in pools]
    for pool in pools:
        pool.set_num_threads(1)
    _depth += 1
    try:
        yield
    finally:
        _depth -= 1
        for pool, n in zip(pools, before, strict=True):
            if n is not None:
                pool.set_num_threads(n)


_depth = 0  # how many one_thread contexts are open
_found: list = [-1, ()]  # (len(sys.modules) when the pools were found, threadpoolctl's pools)


def _pools() -> tuple:
    if _found[0] != len(sys.modules):
        import scipy.linalg  # noqa: F401
        from threadpoolctl import ThreadpoolController

        pools = tuple(ThreadpoolController().lib_controllers)
        _found[:] = [len(sys.modules), pools]
    return _found[1]


def cholesky_lapack():
    """LAPACK's Cholesky factor and solve, ``dpotrf`` and ``dpotrs`` (imported on first use:
    scipy.linalg is slow to import and ``import humanoid`` stays light)."""
    from scipy.linalg import lapack

    return lapack.dpotrf, lapack.dpotrs


def spd_solve(A: np.ndarray, b: np.ndarray, ridge: float = 0.0,
              overwrite: bool = False) -> np.ndarray:  # fmt: skip
    """x with (A + ridge * trace(A) / n * I) x = b for a symmetric positive (semi)definite A,
    by Cholesky; least squares if A is numerically singular. ``overwrite``: A is the caller's
    scratch (the ridge is added in place)."""
    if ridge:
        if not overwrite:
            A = A.copy()
        A.flat[:: len(A) + 1] += ridge * np.trace(A) / len(A)
    potrf, potrs = _lapack or _load_lapack()
    factor, info = potrf(A)
    if info == 0:
        return potrs(factor, b)[0]
    return np.linalg.lstsq(A, b, rcond=1e-12)[0]


_lapack: tuple = ()  # (dpotrf, dpotrs) once loaded


def _load_lapack() -> tuple:
    global _lapack
    _lapack = cholesky_lapack()
    return _lapack
