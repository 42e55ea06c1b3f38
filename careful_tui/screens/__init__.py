"""The screens: play, a study's flow, replay, the fit view (and the reach fit view) and the calibration dialog, all
`Screen`s of one `careful_tui.app.CarefulApp`, and `game_layout` (the layout of play and replay,
and its minimum size). Play, the study and calibration are front ends of `irl_core.play`'s
session; replay draws `irl_core.recordings.replay_cursor`'s frames.

May import: `irl_core`, `careful_tui.render`, `careful_tui.keys`, `careful_tui.widgets`.
Never the app factory, a command or the command line.
"""
