"""The screens: play, replay, the fit view and the calibration dialog, all `Screen`s of one
`careful_app.CarefulApp` (the theme, `careful.tcss`, the driver, the quit keys), `game_layout` (the layout of play
and replay, and its minimum size) and the replay's position in a recording (`replay_cursor`,
no Textual).

May import: `irl_core`, `careful_tui.render`, `careful_tui.keys`, `careful_tui.widgets`.
Never the app factory, a command or the command line.
"""
