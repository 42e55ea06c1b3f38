"""careful's maths: worlds, the MDP, planning, demonstrations and inverse RL. No terminal code."""
