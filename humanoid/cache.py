"""Results kept between runs: the user's cache and the package's data.

Expensive results that depend only on a body and a few numbers (an optimised gait cycle, a
fitted walking cycle) are kept under a name made of the body's digest (:func:`model_key`) and
those numbers, first in the user's cache (``$HUMANOID_CACHE``, default ``~/.cache/humanoid``),
then in the package's data (shipped for the package's own bodies). A file is written whole or
not at all (a run killed half way, or two processes writing the same result, leave no torn
file behind).
"""

from __future__ import annotations

import hashlib
import os
import tempfile
from pathlib import Path

import numpy as np

__all__ = ["CacheWarning", "cache_dir", "model_key", "sources_key", "write_atomic"]

PACKAGE = Path(__file__).resolve().parent


class CacheWarning(UserWarning):
    """A result was computed but could not be kept (a read-only cache folder)."""


def cache_dir(kind: str) -> Path:
    """The user's cache of results of one ``kind`` (``"gaits"``, ``"cycles"``):
    ``$HUMANOID_CACHE/<kind>``, or ``~/.cache/humanoid/<kind>``."""
    root = os.environ.get("HUMANOID_CACHE")
    return (Path(root) if root else Path.home() / ".cache" / "humanoid") / kind


def model_key(model) -> str:
    """A digest of a Pinocchio model's numbers (joints, placements, inertias, limits, frames):
    two bodies with one key move alike under every controller and fit."""
    m = model
    parts = []
    for j in range(1, m.njoints):
        M, inertia = m.jointPlacements[j], m.inertias[j]
        parts += [m.names[j], m.joints[j].shortname(), M.homogeneous.ravel(), inertia.mass,
                  inertia.lever, inertia.inertia.ravel()]  # fmt: skip
    parts += [m.lowerPositionLimit, m.upperPositionLimit, m.effortLimit, m.damping]
    for f in m.frames:
        parts += [f.name, f.parentJoint, f.placement.homogeneous.ravel()]
    with np.errstate(over="ignore"):  # (a free flyer's limits are the largest double)
        text = "|".join(
            np.array2string(np.round(np.asarray(p, dtype=float), 9), threshold=10**6)
            if not isinstance(p, str) else p
            for p in parts
        )  # fmt: skip
    return hashlib.sha256(text.encode()).hexdigest()[:16]


def sources_key(*relative: str) -> str:
    """A digest of the package's own files (paths relative to the package) that compute a
    result: a result kept under it is found again only while they read the same."""
    digest = hashlib.sha256()
    for rel in relative:
        digest.update(rel.encode())
        digest.update((PACKAGE / rel).read_bytes())
    return digest.hexdigest()[:12]


def write_atomic(path: Path, **arrays) -> Path:
    """``np.savez_compressed(path, **arrays)`` through a temporary file in the same folder,
    renamed into place once written."""
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    fd, tmp = tempfile.mkstemp(dir=path.parent, prefix=path.stem, suffix=".tmp.npz")
    try:
        with os.fdopen(fd, "wb") as f:
            np.savez_compressed(f, **arrays)
        os.chmod(tmp, 0o644)  # (mkstemp's file is the owner's alone; a result is for all)
        os.replace(tmp, path)
    except BaseException:
        Path(tmp).unlink(missing_ok=True)
        raise
    return path
