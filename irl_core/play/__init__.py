"""Playing, for any front end: keys into moves (`hold`, `modes`, the registry `input_modes`),
the keyboard's calibration (`calibration`), one play session (`session`) and a study's flow
around its sessions (`study_flow`). The terminal's screens and the browser's server are two
front ends of the same session; `docs/play-session.md` describes its interface.

May import: `irl_core` and the standard library; never a front end (no Textual, no Rich).
"""
