"""Worlds: the built-ins match README "Worlds", and bad worlds get one clear sentence."""

from pathlib import Path

import pytest

import irl_core.worlds.world
from irl_core.errors import WorldError
from irl_core.worlds.world import BUILTIN_WORLDS, World, load_world


def test_builtin_worlds_match_the_spec_table():
    paper, mud = BUILTIN_WORLDS["paper"], BUILTIN_WORLDS["mud"]
    assert paper.grid == ["......", "......", "......", ".CCCCG"]
    assert mud.grid == ["......", ".UU...", "......", ".CCCCG"]
    assert (paper.levels, paper.slip, paper.rewards) == (14, "halving", {"C": -1000.0, "G": 100.0})
    assert BUILTIN_WORLDS["paper-simple"].levels == 1
    assert (BUILTIN_WORLDS["paper-maxent"].levels, BUILTIN_WORLDS["paper-maxent"].slip) == (1, "none")
    assert mud.rewards["U"] == -30.0 and BUILTIN_WORLDS["mud-simple"].levels == 1
    assert (paper.gamma, paper.initial_score, paper.max_steps, paper.start) == (0.95, 200.0, 200, "random")
    # The spec's five, its two time worlds, Gymnasium's CliffWalking layout (tests/env/test_cliffwalking.py)
    # and a walled world.
    assert set(BUILTIN_WORLDS) == {"paper", "paper-simple", "paper-maxent", "mud", "mud-simple", "paper-time",
                                   "mud-time", "cliffwalking", "walls"}


def test_walls_is_a_walled_world_with_a_hazard_a_nuisance_and_a_goal_read_from_its_file():
    walls = BUILTIN_WORLDS["walls"]
    assert load_world("walls") == walls == load_world(Path(irl_core.worlds.world.__file__).parent / "walls.toml")
    symbols = {ch for row in walls.grid for ch in row}
    assert symbols == {".", "#", "C", "U", "G"} and (walls.rows, walls.cols, walls.levels) == (6, 7, 14)
    assert walls.rewards == {"C": -1000.0, "G": 100.0, "U": -30.0}


def test_start_cells_are_the_non_terminal_cells():
    assert len(BUILTIN_WORLDS["paper"].start_cells) == 19  # the paper's "ground" cells
    assert (3, 0) in BUILTIN_WORLDS["paper"].start_cells and (3, 1) not in BUILTIN_WORLDS["paper"].start_cells


def test_toml_round_trip(tmp_path):
    world = BUILTIN_WORLDS["mud"].model_copy(update={"start": (0, 0), "name": "mine"})
    path = tmp_path / "mine.toml"
    path.write_text(world.to_toml())
    assert load_world(path) == world


def _toml(tmp_path, body: str):
    path = tmp_path / "w.toml"
    path.write_text(body)
    return path


@pytest.mark.parametrize(
    ("body", "message"),
    [
        ('layout = """\n...\n..\n"""\n', "ragged: row 0 has 3 cells but row 1 has 2"),
        ('layout = """\n#C\n"""\nstart = [0, 0]\n', "start [0, 0] is a wall"),
        ('layout = """\n.C\n"""\nstart = [0, 1]\n', "start [0, 1] is a terminal cell"),
        ('layout = """\n..\n"""\nstart = [5, 0]\n', "outside the 1x2 grid"),
        ('layout = """\n..\n"""\nlevels = 0\n', "levels: Input should be greater than or equal to 1"),
        ('layout = """\n..\n"""\ngamma = 1.0\n', "gamma: Input should be less than 1"),
        ('layout = """\n..\n"""\ngamma = -0.1\n', "gamma"),
        ('layout = """\nCG\n"""\n', "no cell to start from"),
        ('layout = """\n..\n"""\n[rewards]\nC = -5.0\n', "reward is given for 'C', which the layout does not use"),
        ('layout = """\n..\n"""\nslip = "sometimes"\n', "slip"),
        ('layout = """\n..\n"""\ncolour = "red"\n', "colour: Extra inputs are not permitted"),
        ("layout = [1,\n", "not valid TOML"),
    ],
)
def test_bad_world_files_get_one_clear_line(tmp_path, body, message):
    with pytest.raises(WorldError) as info:
        load_world(_toml(tmp_path, body))
    text = str(info.value)
    assert message in text and "\n" not in text and str(tmp_path) in text


def test_unknown_name_lists_the_builtins():
    with pytest.raises(WorldError, match="no world named 'cliffs'.*paper, paper-simple"):
        load_world("cliffs")


def test_world_files_may_use_other_letters():
    world = World(layout="..X\n.LG\n", terminal=("L", "G"), rewards={"L": -50.0, "X": -1.0})
    assert world.reward_of("X") == -1.0 and world.reward_of(".") == 0.0


@pytest.mark.parametrize(("line", "field"), [("levels = true", "levels"), ('gamma = "0.9"', "gamma"),
                                             ('max_steps = 2.5', "max_steps")])
def test_numbers_of_the_wrong_type_are_reported_not_guessed(tmp_path, line, field):
    with pytest.raises(WorldError, match=f"{field}: Input should be a valid"):
        load_world(_toml(tmp_path, f'layout = """\n..\n"""\n{line}\n'))
