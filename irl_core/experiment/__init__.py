"""The paper's experiment as data (floor 6): its stages and figures' numbers (`run`), each stage's
results (`stage_results`) and the paper's claims judged from a run (`claims`).

May import: every wing below it (`support` to `irl`).
"""
