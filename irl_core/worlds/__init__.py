"""Worlds (floor 1): the world file and the built-in worlds (`world`), the tabular MDP built from a
world (`mdp`) and its transitions in direction form (`moves`), value iteration and soft planning
(`planning`) and the Gymnasium environment (`env`); reach worlds, continuous fields of circles (`reach`),
and what both kinds of world file share as text (`world_text`).

A new built-in world goes in `world.BUILTIN_WORLDS` (or as a ``.toml`` file beside this module), a reach
world in `reach.REACH_WORLDS`.
May import: `irl_core.support`.
"""
