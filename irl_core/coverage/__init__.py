"""Coverage on the user's own design (`careful check`, docs/check.md): simulate datasets of the recordings'
size from a fit and from rival players, refit each as the user fitted, and count how often the intervals
hold the reward the dataset was simulated with.

`rivals` (which person-like players may stand in for the player, per world), `simulate` (one dataset from
the fit's own model of play or from a rival), `check` (the refits, the tally per symbol, the verdict).
Pure functions: no front end is imported here.
"""
