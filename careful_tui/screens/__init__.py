"""The screens: play, replay, the fit view and the calibration dialog, with what they share:
`careful_app` (the theme, `careful.tcss`, the quit keys), `game_layout` (the layout of play
and replay, and its minimum size) and the replay's position in a recording (`replay_cursor`,
no Textual).

May import: `irl_core`, `careful_tui.render`, `careful_tui.keys`, `careful_tui.widgets`.
Never the app factory, a command or the command line.
"""
