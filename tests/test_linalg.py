"""The small dense operations of the per-step paths against NumPy's own."""

from __future__ import annotations

import numpy as np

from humanoid.linalg import cross, spd_solve


def test_cross_equals_numpy_on_stacks_and_broadcasts():
    rng = np.random.default_rng(3)
    a, b = rng.normal(size=(7, 3)), rng.normal(size=(7, 3))
    np.testing.assert_allclose(cross(a, b), np.cross(a, b), rtol=0, atol=1e-14)
    np.testing.assert_allclose(cross(a, b[0]), np.cross(a, b[0]), rtol=0, atol=1e-14)
    np.testing.assert_allclose(cross(a[0], b[0]), np.cross(a[0], b[0]), rtol=0, atol=1e-14)


def test_spd_solve_solves_and_falls_back_on_a_singular_matrix():
    rng = np.random.default_rng(4)
    B = rng.normal(size=(12, 30))
    A, x = B @ B.T, rng.normal(size=12)
    np.testing.assert_allclose(spd_solve(A, A @ x), x, rtol=1e-9, atol=1e-9)
    # rank 11 of 12 (a repeated row): the ridge keeps Cholesky, or least squares answers
    B[11] = B[10]
    A = B @ B.T
    y = spd_solve(A, A @ x, ridge=1e-12)
    np.testing.assert_allclose(A @ y, A @ x, atol=1e-6 * np.abs(A @ x).max())
    z = spd_solve(np.zeros((3, 3)), np.zeros(3))  # not positive definite: least squares
    assert np.array_equal(z, np.zeros(3))


def test_cross_of_two_vectors_is_numpys_to_the_bit():
    """The per-step paths cross single vectors in Python floats: the same products and
    differences as np.cross, so the walks' numbers do not move."""
    rng = np.random.default_rng(5)
    a, b = (
        rng.normal(size=(200, 3)) * 10.0 ** rng.integers(-6, 6, size=(200, 1)),
        rng.normal(size=(200, 3)),
    )
    for x, y in zip(a, b, strict=True):
        assert np.array_equal(cross(x, y), np.cross(x, y))


def test_spd_solve_in_place_gives_the_same_answer():
    rng = np.random.default_rng(6)
    B = rng.normal(size=(10, 25))
    A, b = B @ B.T, rng.normal(size=10)
    want = spd_solve(A, b, ridge=1e-12)
    assert np.array_equal(spd_solve(A.copy(), b, ridge=1e-12, overwrite=True), want)
