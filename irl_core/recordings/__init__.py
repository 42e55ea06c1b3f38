"""Recordings (floor 2): the JSONL lines (`lines`), the writer (`writer`), the reader
(`demonstrations`), lines that must agree (`line_checks`), steps and ends as columns (`column_table`,
`step_table`, `end_table`), a session's summary (`summary`), replay's model (`replay_cursor`) and
export to CSV and Minari (`export`, where a new export format goes).

May import: `irl_core.support`, `irl_core.worlds`.
"""
