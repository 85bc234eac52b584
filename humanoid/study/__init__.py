"""Studies over many runs: a study file (:mod:`~humanoid.study.spec`) names a base scene or
walk and what varies; :func:`run_study` runs it on Dask (a local cluster by default),
resumable, one Parquet row per run; :mod:`~humanoid.study.figures` draws its main result.

Importing this package imports neither Dask nor pyarrow: they load when a study runs.
"""

from .runner import execute
from .spec import OUTPUTS, Run, Study, load_study, parse_study
from .store import read_table
from .sweep import StudyRun, default_folder, run_study

__all__ = [
    "OUTPUTS",
    "Run",
    "Study",
    "StudyRun",
    "default_folder",
    "execute",
    "load_study",
    "parse_study",
    "read_table",
    "run_study",
]
