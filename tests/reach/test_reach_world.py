"""Reach worlds: the built-ins, the file's checks (one line naming the field), the scoring of a reach,
`careful worlds` listing and drawing them, and the commands that do not take them yet refusing in one line."""

import tomllib

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from careful_tui.cli import main
from irl_core.errors import WorldError
from irl_core.worlds.reach import REACH_WORLDS, is_reach_world, load_reach_world, reach_world_from_dict
from irl_core.worlds.world import load_world

GOOD = """name = "mine"
care = "reach"
field = [400, 300]
start = [200, 280]
regions = [
  {symbol = "G", centre = [200, 80], radius = 32, points = 100},
  {symbol = "C", centre = [168, 80], radius = 32, points = -500},
]
noise = "simulated"
spread = {a = 2.0, b = 0.05}
cost_per_second = 20.0
min_ms = 150
max_ms = 1500
"""


def test_the_built_ins_differ_only_in_the_penalty():
    assert {name: world.points for name, world in REACH_WORLDS.items()} == {
        "reach": {"G": 100.0, "C": -500.0}, "reach-mild": {"G": 100.0, "C": -100.0},
        "reach-severe": {"G": 100.0, "C": -5000.0}}


def test_a_world_file_reads_and_its_toml_reads_back_equal(tmp_path):
    path = tmp_path / "mine.toml"
    path.write_text(GOOD)
    world = load_reach_world(path)
    assert is_reach_world(path) and world == REACH_WORLDS["reach"].model_copy(update={"name": "mine"})
    assert reach_world_from_dict(tomllib.loads(world.to_toml())) == world


@pytest.mark.parametrize(("change", "field", "words"), [
    ({"regions": [{"symbol": "G", "centre": [390, 80], "radius": 32, "points": 100}]}, "regions.0",
     "reaches outside the field"),
    ({"regions": [{"symbol": "G", "centre": [200, 80], "radius": -3, "points": 100}]}, "regions.0.radius",
     "greater than 0"),
    ({"spread": {"a": 2.0, "b": -0.1}}, "spread.b", "greater than or equal to 0"),
    ({"min_ms": 1500}, "min_ms", "is not below max_ms"),
    ({"start": [500, 10]}, "start", "outside the field"),
    ({"regions": [{"symbol": "G", "centre": [200, 80], "radius": 3, "points": 1},
                  {"symbol": "G", "centre": [100, 80], "radius": 3, "points": 2}]}, "regions.1.points",
     "one value of points"),
    ({"noise": "mouse"}, "noise", "'simulated' or 'own'"),
])
def test_a_bad_field_is_one_line_naming_file_and_field(tmp_path, change, field, words):
    data = {**tomllib.loads(GOOD), **change}
    with pytest.raises(WorldError) as caught:
        reach_world_from_dict(data, source="bad.toml")
    message = str(caught.value)
    assert "\n" not in message and message.startswith(f"bad.toml: {field}") and words in message


def test_the_circles_holding_an_endpoint_and_the_time_cost():
    world = REACH_WORLDS["reach"]
    assert world.regions_holding((184.0, 80.0)) == ["G", "C"]
    assert world.regions_holding((232.0, 80.0)) == ["G"]  # on the rim
    assert world.regions_holding((10.0, 10.0)) == []
    assert world.cost([500.0, 1500.0]).tolist() == pytest.approx([10.0, 30.0])


def test_the_spread_law_shrinks_with_time():
    world = REACH_WORLDS["reach"]
    # distance 200 from the start: sd = 2 + 0.05 * 200 / seconds
    assert world.sd((200.0, 80.0), [500.0, 1000.0]).tolist() == pytest.approx([22.0, 12.0])


def test_careful_worlds_lists_and_draws_reach_worlds(capsys, monkeypatch):
    monkeypatch.setenv("COLUMNS", "200")
    assert main(["worlds"]) == 0
    listed = capsys.readouterr().out
    assert all(name in listed for name in ("reach-mild", "reach-severe"))
    assert main(["worlds", "--show", "reach-severe"]) == 0
    drawn = capsys.readouterr().out
    rows = drawn.splitlines()
    assert "a reach world, field 400x300" in rows[0]
    field = [row for row in rows[1:] if set(row) <= set(".GC+S") and len(row) == 60]
    assert len(field) == 22 and any("+" in row for row in field) and sum(row.count("S") for row in field) == 1
    # The target is right of the penalty, as in the file.
    band = next(row for row in field if "+" in row)
    assert band.index("C") < band.index("+") < band.index("G")
    assert "points = -5000.0" in drawn


def test_study_run_refuses_a_reach_world_and_play_an_own_noise_one_in_one_line(tmp_path, capsys):
    own = tmp_path / "own.toml"
    own.write_text(GOOD.replace('noise = "simulated"', 'noise = "own"'))
    assert main(["play", "--world", str(own), "--out", str(tmp_path / "rec")]) == 2
    error = capsys.readouterr().err.strip()
    assert len(error.splitlines()) == 1 and 'noise = "own"' in error and "careful serve" in error
    assert not (tmp_path / "rec").exists()  # refused before anything was made
    world = tmp_path / "mine.toml"
    world.write_text(GOOD)
    with pytest.raises(WorldError, match="is a reach world"):
        load_world(world)
    study = tmp_path / "study.toml"
    study.write_text(f'worlds = ["{world}"]\ninput = "hold"\nout = "data"\n')
    # careful serve takes it (tests/web/test_reach_page.py); the terminal's study run does not.
    assert main(["study", "run", str(study), "--participant", "p1"]) == 2
    error = capsys.readouterr().err.strip()
    assert len(error.splitlines()) == 1 and "does not take reach worlds" in error and "careful serve" in error
    assert not (tmp_path / "data").exists()


@settings(max_examples=40, deadline=None)
@given(st.data())
def test_any_valid_world_reads_back_equal_from_its_toml(data):
    width, height = data.draw(st.floats(50, 2000)), data.draw(st.floats(50, 2000))
    regions = []
    for symbol in data.draw(st.lists(st.sampled_from("GCUXé"), min_size=1, max_size=4, unique=True)):
        radius = data.draw(st.floats(1, min(width, height) / 2))
        centre = [data.draw(st.floats(radius, width - radius)), data.draw(st.floats(radius, height - radius))]
        regions.append({"symbol": symbol, "centre": centre, "radius": radius,
                        "points": data.draw(st.floats(-1e6, 1e6))})
    low = data.draw(st.floats(1, 5000))
    world = reach_world_from_dict({
        "name": data.draw(st.text(max_size=12)), "care": "reach", "field": [width, height],
        "start": [data.draw(st.floats(0, width)), data.draw(st.floats(0, height))], "regions": regions,
        "spread": {"a": data.draw(st.floats(0.01, 50)), "b": data.draw(st.floats(0, 1))},
        "cost_per_second": data.draw(st.floats(0, 1000)), "min_ms": low, "max_ms": low + data.draw(st.floats(1, 5000)),
    })
    assert reach_world_from_dict(tomllib.loads(world.to_toml())) == world
