"""Players that are not people (floor 4): computer experts, optimal and Boltzmann, and their
rollouts (`experts`), and person-like players with a hand and lapses (`person_like`).

May import: `irl_core.support`, `worlds`, `recordings`, `play`.
"""
