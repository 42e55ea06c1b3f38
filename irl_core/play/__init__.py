"""Playing, for any front end (floor 3): the game's rules (`game`), keys into moves (`hold`, `modes`,
the registry `input_modes`, where a new input mode goes), the keyboard's calibration
(`calibration`) and one play session (`session`). The terminal's screens and the browser's server
are two front ends of the same session; `docs/play-session.md` describes its interface.

May import: `irl_core.support`, `worlds`, `recordings`; never a front end (no Textual, no Rich).
"""
