"""A small two-world study for the `careful study run` tests (Pilot and tmux): digits input, fixed order."""

from __future__ import annotations

from pathlib import Path

# Two worlds where one move ends an episode: in "right" the goal is to the right of the start,
# in "left" the cliff is to its left. Moving up from either start bumps the top edge: the
# episode goes on.
RIGHT = """\
name = "right"
layout = "..G"
levels = 5
slip = "none"
start = [0, 1]
[rewards]
G = 100.0
"""
LEFT = """\
name = "left"
layout = "C.."
levels = 9
slip = "none"
start = [0, 1]
[rewards]
C = -1000.0
"""
STUDY = """\
name = "pilot"
instructions = \"\"\"Welcome. [bold]This is not markup[/bold] \\u001b[31m
Reach the goal.\"\"\"
worlds = ["right.toml", "left.toml"]
order = "fixed"
practice_episodes = {practice}
calibration_block = {calibration}
episodes = 2
input = "digits"
out = "data"
"""


def write_study(folder: Path, *, practice: int = 1, calibration: int = 0) -> Path:
    (folder / "right.toml").write_text(RIGHT)
    (folder / "left.toml").write_text(LEFT)
    path = folder / "pilot.toml"
    path.write_text(STUDY.format(practice=practice, calibration=calibration))
    return path
