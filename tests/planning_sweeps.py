"""Counting value iteration's sweeps (`MDP.expected_next` calls: one P V a sweep, and one more for
Q once it has converged): how the stop tests say "promptly" without timing anything."""

from irl_core.worlds.mdp import MDP


def count_sweeps(monkeypatch) -> list[int]:
    """[n], the backups P V computed since this call (reset it by assigning to [0])."""
    done = [0]
    real = MDP.expected_next

    def counted(self, V):
        done[0] += 1
        return real(self, V)

    monkeypatch.setattr(MDP, "expected_next", counted)
    return done
