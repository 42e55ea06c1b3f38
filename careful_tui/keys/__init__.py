"""The terminal's keys: the driver that reports key releases (`kitty`) and when a key event
reached the app (`arrival`). Keys into moves, the input modes and calibration are the play
session's, in `irl_core.play`, shared with every front end.

`kitty` is the one module in the project that touches Textual's private API (`textual._*`); its
docstring names the Textual release it was written against, and a test holds the installed one to it.
May import: `irl_core` and Textual. Never render, widgets, screens, the app or a command.
"""
