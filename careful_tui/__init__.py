"""careful's terminal: the game, replay, the fit view and the command line.

Layers, each importing only from those above it in this list (a test reads the imports):

- `irl_core`: the maths and the file formats (no terminal code).
- `errors`, `version`, `arguments`, `option_words`: exit codes and `UsageError`; the version; parsed
  arguments into the core's options; the core's notes in the command line's words (fit()'s
  parameters as flags).
- `render`: pictures without an app (Rich renderables, matplotlib figures); no Textual.
- `keys`: the kitty terminal driver (key releases), when a key event reached the app, and whether
  the terminal reports releases. Keys into moves (hold, tap, digits, calibration) are the play
  session's, in `irl_core.play`.
- `widgets`: the board, the gauge, the key bar, play's status and the too-small notice.
- `screens`: play, a study's flow, replay, the fit view, calibration and the motor calibration block.
- `app`: the factories that build an app, shared by the command line and the tests.
- `web`: `careful serve`, the browser's front end (beside `app`: no Textual, no screen, no widget).
- `commands`: one module per `careful` command.
- `cli`: the argument parser and `main`.
- `entry`: the console script, which says which extra to install when one is missing.
"""
