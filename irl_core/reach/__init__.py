"""Reach worlds' players and fit (between floor 4, `players`, and floor 5, `irl`): the expected gain of a reach and
the grid of choices (`gain`), the computer reachers (`players`), and the fit of each circle's points and
the spread law (`fit`). The world file itself is `irl_core.worlds.reach`; the recording's lines are
`irl_core.recordings.reach_lines` (docs/reach.md).

May import: `irl_core.support`, `worlds`, `recordings`, `play`, `players`.
"""
