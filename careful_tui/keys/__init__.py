"""The terminal's keys: the driver that reports key releases (`kitty`) and when a key event
reached the app (`arrival`). Keys into moves, the input modes and calibration are the play
session's, in `irl_core.play`, shared with every front end.

`kitty` is the one module in the project that touches Textual's private API (`textual._*`); it
checks the Textual version it was written against.
May import: `irl_core` and Textual. Never render, widgets, screens, the app or a command.
"""
