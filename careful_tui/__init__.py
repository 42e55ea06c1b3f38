"""careful's terminal: the game, replay, the fit view and the command line.

Layers, each importing only from those above it in this list (a test reads the imports):

- `irl_core`: the maths and the file formats (no terminal code).
- `errors`, `version`, `arguments`: exit codes and `UsageError`; the version; parsed
  arguments into the core's options.
- `render`: pictures without an app (Rich renderables, matplotlib figures); no Textual.
- `keys`: keys into moves (hold, tap, digits, calibration) and the kitty terminal driver.
- `widgets`: the board, the gauge, the key bar.
- `screens`: play, replay, the fit view, calibration.
- `app`: the factories that build an app, shared by the command line and the tests.
- `web`: `careful serve`, the browser's front end (beside `app`: no Textual, no screen, no widget).
- `option_words`: the core's notes in the command line's words (fit()'s parameters as flags).
- `commands`: one module per `careful` command.
- `cli`: the argument parser and `main`.
- `entry`: the console script, which says which extra to install when one is missing.
"""
