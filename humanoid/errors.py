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


class StudyError(HumanoidError, ValueError):
    """A study file is invalid: it names the file and the key (unknown parameter, wrong type,
    a body out of range, a scene value the scene refuses), or its output folder holds another
    study's results."""


class TrajectoryError(HumanoidError, ValueError):
    """A saved run (.npz) cannot be read: missing, truncated, corrupt or inconsistent."""


class WalkError(HumanoidError, ValueError):
    """A walk that cannot be set up: its parameters (steps, speed, radius, direction, a plan's
    lengths) out of range, or a body without what walking needs (an ankle below the knee)."""


class ControlError(HumanoidError, ValueError):
    """A controller's task or gain that is not one it knows or can use."""


class OptimalControlError(HumanoidError, ValueError):
    """An optimal-control problem that cannot be posed with these inputs (an objective or a
    transition it does not know, a body without the contact frames a gait needs), or a saved
    cycle that is not one of this body's."""


class ConvergenceError(HumanoidError):
    """A solver (IPOPT) that did not converge: its status and iterations in the message."""


class BenchError(HumanoidError):
    """A benchmark that has nothing to measure (no scenes found)."""


class UsageError(HumanoidError, ValueError):
    """A command line that cannot run: an option out of its range (the message names the
    option and what it accepts), options that do not go together, an output path that cannot
    be written."""


class MarkerSetError(HumanoidError, ValueError):
    """A marker set that cannot be used: not a known set or a marker-set TOML, a marker without
    a frame, offset or weight, or a set that does not fit the trial (no label in common, labels
    of two subjects) or the body (a frame it does not have)."""


class CoordinateMapError(HumanoidError, ValueError):
    """A coordinate map (TOML) that cannot be used: an unknown key, a joint without columns,
    axes that are not x, y, z, or a joint the body does not have."""


class KeypointError(HumanoidError, ValueError):
    """Keypoints that cannot be used: an unknown layout, arrays of the wrong shape, times that
    do not increase, or nothing seen."""


class CameraError(HumanoidError, ValueError):
    """A camera that cannot be placed or paired with its keypoints (a calibration with another
    number of cameras than the keypoints have)."""


class IKError(HumanoidError, ValueError):
    """Inverse kinematics that cannot be posed: fewer than 3 markers seen in a frame, no marker
    of the trial in the set, a setting out of range, keypoints without cameras."""


class ScalingError(HumanoidError, ValueError):
    """A body that cannot be scaled to a static trial: not one of the toolkit's bodies, no
    marker or measurement in common, a ratio out of range, an unknown mode."""


class InverseDynamicsError(HumanoidError, ValueError):
    """Inverse dynamics (or residual reduction) that cannot be posed: too few samples, a time
    that does not increase, a filter cutoff out of range, a load on a body part there is not."""


class OpenSimError(HumanoidError):
    """An OpenSim tool (scale, inverse kinematics, inverse dynamics) that failed, or a joint
    with no OpenSim counterpart."""


class ViewerError(HumanoidError, ValueError):
    """The viewer cannot show this: an unknown camera, a playback speed or frame rate out of
    range, a run too short or too long to animate, geometry it cannot load, a server that did
    not start."""


class MissingExtra(HumanoidError, ImportError):
    """An optional dependency is not installed: the message names the ``pip install`` that
    brings it (:func:`require`)."""


class ExtraConflict(HumanoidError, ImportError):
    """Two optional dependencies that cannot share a process (OpenSim's wheel bundles its own
    casadi libraries)."""


# the optional dependencies and the extra of humanoid-toolkit that installs each
EXTRAS = {"ezc3d": "c3d", "dask": "studies", "distributed": "studies", "pyarrow": "studies",
          "mujoco": "mujoco", "opensim": "opensim", "casadi": "optimal"}  # fmt: skip


def require(module: str, what: str):
    """The module ``module`` (a dotted name: ``"pyarrow.parquet"``) imported, or a
    :class:`MissingExtra` saying that ``what`` needs it and which extra installs it."""
    import importlib

    try:
        return importlib.import_module(module)
    except ImportError as exc:
        top = module.split(".")[0]
        raise MissingExtra(
            f"{what} needs {top}, which is not installed: pip install "
            f"'humanoid-toolkit[{EXTRAS.get(top, top)}]'"
        ) from exc


class DivergenceError(HumanoidError):
    """A simulation diverged: non-finite or exploding state, or a step size that collapsed."""


MAX_STATE = 1e6  # [m, rad, m/s, rad/s] no entry of a body's state is larger


def finite_vector(x, n: int, what: str, size: str) -> np.ndarray:
    """``x`` as a flat float array of ``n`` finite entries of at most :data:`MAX_STATE`; else
    ConfigurationError naming ``what`` and its ``size`` symbol, as in "q must have nq = 47
    entries"."""
    if x is None or isinstance(x, str | bytes | dict):
        raise ConfigurationError(f"{what} must be {n} numbers ({size}), got {type(x).__name__}")
    try:
        x = np.array(x, dtype=float).reshape(-1)  # a copy: callers may normalise it
    except (TypeError, ValueError, OverflowError) as exc:
        raise ConfigurationError(f"{what} must be {n} numbers ({size}): {exc}") from None
    if x.shape != (n,):
        raise ConfigurationError(f"{what} must have {size} = {n} entries, got {x.shape[0]}")
    if not np.all(np.isfinite(x)):
        bad = np.flatnonzero(~np.isfinite(x))
        raise ConfigurationError(f"{what} has non-finite entries (at {bad[:8].tolist()})")
    if np.abs(x).max(initial=0.0) > MAX_STATE:
        raise ConfigurationError(
            f"{what} has entries beyond {MAX_STATE:g} (largest {np.abs(x).max():.3g}): "
            "not the state of a body"
        )
    return x


def finite_rows(x, n: int, what: str, size: str, rows: int | None = None) -> np.ndarray:
    """One state or a sequence of them as (N, n) floats (a copy), each row checked as
    :func:`finite_vector` checks one; ``rows``: the N it must have (a state's velocities for
    its configurations)."""
    if np.ndim(x) < 2:
        out = finite_vector(x, n, what, size)[None]
    else:
        try:
            out = np.array(x, dtype=float)
        except (TypeError, ValueError, OverflowError) as exc:
            raise ConfigurationError(
                f"{what} must be rows of {n} numbers ({size}): {exc}"
            ) from None
        if out.ndim != 2 or out.shape[1] != n:
            raise ConfigurationError(f"{what} must be rows of {size} = {n} entries, got shape "
                                     f"{out.shape}")  # fmt: skip
        for row in out[~np.isfinite(out).all(axis=1) | (np.abs(out).max(axis=1) > MAX_STATE)]:
            finite_vector(row, n, what, size)  # raises, naming the first bad row's entries
    if rows is not None and len(out) != rows:
        raise ConfigurationError(f"{what} has {len(out)} rows for {rows} states")
    return out


class RunFailed(HumanoidError):
    """A run's task failed: the body fell, or its controller found no solution. The run stops
    and keeps what it computed (status ``failed``)."""
