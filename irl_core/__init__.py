"""careful's maths: worlds, the MDP, planning, demonstrations and inverse RL. No terminal code.

May import: numpy, scipy, cvxpy, highspy, pydantic and itself; never `careful_tui`, Rich or
Textual (a test reads the imports).
"""
