"""Keys into moves: the hold detector and the other input modes (`hold`, `modes`), the
autorepeat calibration (`calibration`), and the terminal driver that reports key releases
(`kitty`).

`hold`, `modes` and `calibration` import neither Textual nor Rich: they take an injectable
clock and are tested by hand. `kitty` is the one module in the project that touches Textual's
private API (`textual._*`); it checks the Textual version it was written against.
May import: `irl_core` and Textual. Never render, widgets, screens, the app or a command.
"""
