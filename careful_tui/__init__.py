"""careful's terminal: the game, replay, the fit view and the command line."""
