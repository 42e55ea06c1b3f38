"""Counting maxent's objective evaluations (`maxent._likelihood`: one soft Bellman fixed point
and its gradient each): how the stop tests say "promptly" without timing anything."""

from irl_core.irl import maxent


def count_evaluations(monkeypatch) -> list[int]:
    """[n], the evaluations finished since this call (reset it by assigning to [0])."""
    finished = [0]
    real = maxent._likelihood

    def counted(*args, **kwargs):
        answer = real(*args, **kwargs)
        finished[0] += 1
        return answer

    monkeypatch.setattr(maxent, "_likelihood", counted)
    return finished
