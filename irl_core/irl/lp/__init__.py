"""The paper's simple IRL agent as linear programs (docs/fitting.md), solved with HiGHS.

==========  ====================================================================================
`margin`    the agent's constraints and its margin LP as sparse arrays over x = [theta; V]
`solve`     the margin LP solved by row generation (the maths of the constraints is there)
`highs`     one way to state a linear program, solve it with HiGHS and read what HiGHS said
==========  ====================================================================================

The identified set over these constraints is an interval kind (`irl_core.irl.intervals.identified`).
"""
