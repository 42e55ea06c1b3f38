"""The screens: play, replay, the fit view and the calibration dialog, with the layout play
and replay share (`game_layout`) and the replay's position in a recording (`replay_cursor`,
no Textual).

May import: `irl_core`, `careful_tui.render`, `careful_tui.keys`, `careful_tui.widgets`.
Never the app factory, a command or the command line.
"""
