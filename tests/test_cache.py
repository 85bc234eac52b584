"""Results kept between runs (humanoid.cache): a fitted walking cycle read back is the fit
itself, found only for the same body, numbers and fitting code, and never a torn file."""

from __future__ import annotations

import numpy as np
import pytest

import humanoid as hm
from humanoid.cache import CacheWarning, model_key, write_atomic
from humanoid.data import BODIES
from humanoid.model import lock_foot_hinges
from humanoid.walking import reference
from humanoid.walking.reference import CYCLES, cycle_file, fit_cycle, read_cycle, write_cycle


@pytest.fixture(scope="module")
def male():
    return lock_foot_hinges(hm.load(BODIES / "adult_male.urdf"))


def assert_same_cycle(a, b):
    assert a.gait == b.gait and a.residual == b.residual
    assert np.array_equal(a.phase, b.phase) and np.array_equal(a.q, b.q)
    for s in ("left", "right"):
        assert np.array_equal(a.feet[s], b.feet[s])
        assert np.array_equal(a.contact[s], b.contact[s])
    for k in ("phase", "c", "dc", "ddc", "zmp", "stride", "period"):
        assert np.array_equal(getattr(a.com, k), getattr(b.com, k)), k


def test_the_shipped_cycle_is_the_fit_itself(male, tmp_path, monkeypatch):
    """The package's cycle of the male body at 0.8 m/s (which the tests and the studies walk)
    equals a fit made now, to the last bit: a file written from another fitting code, or a
    field read back wrong, fails here."""
    monkeypatch.setenv("HUMANOID_CACHE", str(tmp_path))
    name = cycle_file(male, 0.8, None, reference.FRAMES)
    assert (CYCLES / name).is_file(), "shipped cycles are stale: run `make cycles`"
    fitted = fit_cycle(male, 0.8, cache=False)
    assert_same_cycle(read_cycle(CYCLES / name), fitted)
    assert_same_cycle(fit_cycle(male, 0.8), fitted)
    assert not (tmp_path / "cycles").exists()  # found in the package: nothing fitted or kept


def test_the_package_ships_the_cycles_the_walks_fit(male):
    """The free-speed and 0.8 m/s cycles of both bodies with their toes locked (the person's
    walk with ``--gait human``, the tests, the studies) are shipped for this very fitting
    code: a change to it without `make cycles` would make every walk fit again."""
    female = lock_foot_hinges(hm.load(BODIES / "adult_female.urdf"))
    for h in (male, female):
        for speed in (None, 0.8):
            s = reference.free_speed(reference.leg_length(h)) if speed is None else speed
            assert (CYCLES / cycle_file(h, s, None, reference.FRAMES)).is_file(), (h.name, speed)


def test_the_name_changes_with_the_body_and_every_number(male):
    base = cycle_file(male, 0.8, None, 50)
    others = [cycle_file(male, 0.81, None, 50), cycle_file(male, 0.8, 0.2, 50),
              cycle_file(male, 0.8, None, 40)]  # fmt: skip
    heavier = lock_foot_hinges(hm.load(BODIES / "adult_male.urdf"))
    heavier.model.inertias[3].mass += 0.1
    others.append(cycle_file(heavier, 0.8, None, 50))
    assert base not in others and len(set(others)) == len(others)
    assert model_key(heavier.model) != model_key(male.model)


def test_a_damaged_or_foreign_file_is_fitted_again_and_replaced(male, tmp_path, monkeypatch):
    monkeypatch.setenv("HUMANOID_CACHE", str(tmp_path))
    monkeypatch.setattr(reference, "CYCLES", tmp_path / "none")  # not the package's
    shipped = read_cycle(CYCLES / cycle_file(male, 0.8, None, 50))
    calls = []

    def fake_fit(h, speed, width, frames):
        calls.append(speed)
        return shipped

    monkeypatch.setattr(reference, "_fit", fake_fit)
    path = tmp_path / "cycles" / cycle_file(male, 0.8, None, 50)
    path.parent.mkdir()
    path.write_bytes(b"PK\x03\x04 torn")
    assert_same_cycle(fit_cycle(male, 0.8), shipped)
    assert calls == [0.8]
    assert_same_cycle(read_cycle(path), shipped)  # replaced whole
    fit_cycle(male, 0.8)
    assert calls == [0.8]  # and found the second time
    assert [p.name for p in path.parent.iterdir()] == [path.name]  # no temporary left


def test_a_cache_that_cannot_be_written_warns_and_the_fit_is_returned(male, tmp_path,
                                                                      monkeypatch):  # fmt: skip
    blocker = tmp_path / "file"
    blocker.write_text("")
    monkeypatch.setenv("HUMANOID_CACHE", str(blocker))  # a file where the folder would go
    monkeypatch.setattr(reference, "CYCLES", tmp_path / "none")
    shipped = read_cycle(CYCLES / cycle_file(male, 0.8, None, 50))
    monkeypatch.setattr(reference, "_fit", lambda *a: shipped)
    with pytest.warns(CacheWarning, match="not cached"):
        assert fit_cycle(male, 0.8) is shipped


def test_an_interrupted_write_leaves_no_file(tmp_path):
    class Boom:
        def __array__(self, *a, **k):
            raise KeyboardInterrupt

    with pytest.raises(KeyboardInterrupt):
        write_atomic(tmp_path / "x.npz", a=np.zeros(3), b=Boom())
    assert list(tmp_path.iterdir()) == []


def test_write_and_read_round_trip(male, tmp_path):
    shipped = read_cycle(CYCLES / cycle_file(male, 0.8, None, 50))
    assert_same_cycle(read_cycle(write_cycle(shipped, tmp_path / "c.npz")), shipped)
