"""A person's motion in and its forces out: OpenSim Storage files, external loads, inverse
dynamics (more readers, inverse kinematics and tracking join as they land).

Nothing here is imported by ``import humanoid``; ``import humanoid.motion`` loads numpy, scipy
and Pinocchio only.
"""

from __future__ import annotations

from .storage import MotionFileError, Table, read_storage, write_csv, write_storage

__all__ = ["MotionFileError", "Table", "read_storage", "write_csv", "write_storage"]
