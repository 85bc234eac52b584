"""Errors raised where input enters the toolkit.

Every error the toolkit raises on purpose derives from :class:`HumanoidError`, so callers can
catch one type. Messages say what was wrong and what would be valid.
"""

from __future__ import annotations

import numpy as np


class HumanoidError(Exception):
    """Base class of every error raised by humanoid on purpose."""


class BodyParameterError(HumanoidError, ValueError):
    """A body parameter (height, mass, sex, segment length) is out of its valid range."""


class ModelError(HumanoidError):
    """A URDF or model cannot be used: missing file, malformed XML, bad inertia, no feet..."""


class ConfigurationError(HumanoidError, ValueError):
    """A configuration or velocity vector has the wrong size or non-finite entries."""


class SceneError(HumanoidError, ValueError):
    """A scene file or scene value is invalid (unknown key, wrong type, impossible value)."""


class DivergenceError(HumanoidError):
    """A simulation diverged: non-finite or exploding state, or a step size that collapsed."""


def finite_vector(x, n: int, what: str, size: str) -> np.ndarray:
    """``x`` as a flat float array of ``n`` finite entries; else ConfigurationError naming
    ``what`` and its ``size`` symbol, as in "q must have nq = 47 entries"."""
    x = np.asarray(x, dtype=float).reshape(-1)
    if x.shape != (n,):
        raise ConfigurationError(f"{what} must have {size} = {n} entries, got {x.shape[0]}")
    if not np.all(np.isfinite(x)):
        raise ConfigurationError(f"{what} has non-finite entries")
    return x
