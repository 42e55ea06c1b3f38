"""Recordings (floor 2): the JSONL lines (`lines`), the writer (`writer`), the reader
(`demonstrations`), lines that must agree (`line_checks`), steps and ends as columns (`column_table`,
`step_table`, `end_table`), a session's summary (`summary`), replay's model (`replay_cursor`), export to
CSV, Minari and Psych-DS (`export`, where a new export format goes; `reach_export` for reach recordings),
and another lab's trial table made
recordings (`importing`, through its column map `table_map` and its reader `trial_table`).

May import: `irl_core.support`, `irl_core.worlds`.
"""
