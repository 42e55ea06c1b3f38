"""A study's report, as plain data: per participant and pooled fits per world (docs/studies.md).

The report's face; each job has its module:

================  ===================================================================================
`report_cells`    `gather`: every participant's finished main episodes per world, and each world's pool
`report_fits`     `fit_report`: the participants' fits, the exclusions, and each pool by its model
                  (the population of participants by default, `irl_core.studies.population`)
`report_table`    `report_rows`: the CSV; `pooled_finding`: what a pooled row shows, in a sentence
================  ===================================================================================
"""

from irl_core.irl.choices import DEFAULT_POOL_MODEL, POOL_MODELS
from irl_core.studies.report_cells import (
    POOLED,
    Cell,
    StudyData,
    gather,
    influence_cells,
    leave_out,
    participant_ids,
    without_participants,
)
from irl_core.studies.report_fits import (
    CellFit,
    Influence,
    excluded_why,
    fit_cell,
    fit_report,
    influence_of,
    report_options,
    run_fits,
    with_influence,
)
from irl_core.studies.report_table import REWARD_COLUMNS, pooled_finding, report_rows, report_symbols

__all__ = ["DEFAULT_POOL_MODEL", "POOLED", "POOL_MODELS", "REWARD_COLUMNS", "Cell", "CellFit", "Influence",
           "StudyData", "excluded_why", "fit_cell", "fit_report", "gather", "influence_cells",
           "influence_of", "leave_out", "participant_ids", "pooled_finding", "report_options", "report_rows",
           "report_symbols", "run_fits", "with_influence", "without_participants"]
