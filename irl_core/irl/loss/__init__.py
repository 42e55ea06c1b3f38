"""The paper's loss IRL agent (docs/fitting.md): a convex loss for demonstrations that are not quite optimal.

=========  ===============================================================================
`model`    the problem: the loss, its constraints and why it is convex
`solve`    the solver: the loss minimised exactly by outer approximation with HiGHS
=========  ===============================================================================
"""
