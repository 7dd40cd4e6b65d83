"""Parametric sweeps: vary scenario keys, run every case as a dask task, gather one table and one figure.

::

    from geocel.sweep import Study, run_study
    study = Study.from_toml("examples/sweep_friction.toml")   # every case validated here
    [c.name for c in study.cases()]                            # run-directory names from the varied values
    table = run_study(study, "sweeps/friction", workers=2)    # pandas.DataFrame, one row per case

The study file and the table are described in docs/sweeps.md; the command line is ``geocel sweep FILE``.
"""

from .run import COLUMNS, StudyPlan, plan_study, run_study, study_table
from .study import Case, Study, StudyError, expand_range

__all__ = [
    "COLUMNS",
    "Case",
    "Study",
    "StudyError",
    "StudyPlan",
    "expand_range",
    "plan_study",
    "run_study",
    "study_table",
]
