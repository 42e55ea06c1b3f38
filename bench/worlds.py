"""Generated cliff worlds for the benchmarks: the paper's layout stretched to any size."""

from irl_core.worlds.world import World


def cliff_world(rows: int, cols: int, *, levels: int = 14) -> World:
    """`rows` x `cols` ground with the bottom row a cliff from column 1 and the goal at its end."""
    layout = "\n".join(["." * cols] * (rows - 1) + ["." + "C" * (cols - 2) + "G"]) + "\n"
    return World(name=f"cliff-{rows}x{cols}", layout=layout, levels=levels, rewards={"C": -1000.0, "G": 100.0})
