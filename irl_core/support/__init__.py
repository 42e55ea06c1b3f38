"""Support every wing uses (floor 0): safe writes and reads (`safe_files`), text made safe to show
(`safe_text`), formula-safe CSV cells (`csv_cells`), a count with its noun (`plural`), the process pool that
dies with its parent (`pool`) and the stop check a long loop polls (`stopping`).

May import: the standard library, numpy and itself; nothing else of `irl_core`.
"""
