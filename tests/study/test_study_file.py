"""The study file: what it holds, one-line errors naming file and field, and the shuffled order."""

import hashlib

import pytest
from study.conftest import write_study

from irl_core.errors import StudyError
from irl_core.studies.study import Study, load_study, world_order


def test_a_study_file_reads_with_worlds_relative_to_it(tmp_path):
    (tmp_path / "worlds").mkdir()
    (tmp_path / "worlds" / "tiny.toml").write_text('layout = """\n..G\n.CC\n"""\nlevels = 3\n[rewards]\nC = -10.0\n')
    path = write_study(tmp_path, worlds='["paper", "worlds/tiny.toml"]', order="fixed", practice=0, episodes=4)
    loaded = load_study(path)
    assert [w.name for w in loaded.worlds] == ["paper", "tiny"]
    assert loaded.study.episodes == 4 and loaded.study.practice_episodes == 0 and loaded.study.input == "digits"
    assert loaded.out == tmp_path / "data"
    assert loaded.participant_folder("p7") == tmp_path / "data" / "p7"
    assert loaded.report_folder == tmp_path / "data" / "report"


@pytest.mark.parametrize(("text", "message"), [
    ('worlds = []', "pilot.toml: worlds: Tuple should have at least 1 item"),
    ('worlds = ["paper"]\norder = "random"', "pilot.toml: order: Input should be 'fixed' or 'shuffled'"),
    ('worlds = ["paper"]\nepisodes = 0', "pilot.toml: episodes: Input should be greater than or equal to 1"),
    ('worlds = ["paper"]\nepisodes = "5"', "pilot.toml: episodes: Input should be a valid integer"),
    ('worlds = ["paper"]\nparticipants = 3', "pilot.toml: participants: Extra inputs are not permitted"),
    ('worlds = ["paper", "nowhere.toml"]', "pilot.toml: worlds[1]: 'nowhere.toml' is neither a built-in world"),
    ('worlds = ["paper"', "pilot.toml: not valid TOML"),
    (f'worlds = ["paper"]\ninstructions = "{"x" * 20_001}"', "pilot.toml: instructions: String should have at most 20000"),
])
def test_a_bad_study_file_is_one_line_naming_file_and_field(tmp_path, text, message):
    path = tmp_path / "pilot.toml"
    path.write_text(text)
    with pytest.raises(StudyError) as caught:
        load_study(path)
    assert message in str(caught.value)
    assert "\n" not in str(caught.value)


def test_a_bad_world_file_names_the_study_entry_and_the_world_field(tmp_path):
    (tmp_path / "bad.toml").write_text('layout = """\n..G\n.C\n"""\n')
    with pytest.raises(StudyError, match=r"pilot.toml: worlds\[0\]: .*bad.toml: layout: .*ragged"):
        load_study(write_study(tmp_path, worlds='["bad.toml"]'))


def test_the_study_name_defaults_to_the_file_name(tmp_path):
    path = tmp_path / "spring.toml"
    path.write_text('worlds = ["paper"]\n')
    assert load_study(path).study.name == "spring"


def test_a_fixed_order_is_the_files():
    assert world_order(Study(name="s", worlds=("a", "b", "c")), "anyone") == [0, 1, 2]


def test_shuffled_orders_worked_by_hand():
    """Three worlds: draw i is sha256("<id>:<i>") mod (i + 1), from i = 2 down to 1.

    p01: "p01:2" mod 3 = 2 (no swap), "p01:1" mod 2 = 0 (swap places 1 and 0): [1, 0, 2].
    p02: "p02:2" mod 3 = 0 (swap 2 and 0: [2, 1, 0]), "p02:1" mod 2 = 0 (swap 1 and 0): [1, 2, 0].
    """
    def draw(text: str, n: int) -> int:
        return int.from_bytes(hashlib.sha256(text.encode()).digest(), "big") % n

    assert (draw("p01:2", 3), draw("p01:1", 2), draw("p02:2", 3), draw("p02:1", 2)) == (2, 0, 0, 0)
    study = Study(name="s", worlds=("a", "b", "c"), order="shuffled")
    assert world_order(study, "p01") == [1, 0, 2]
    assert world_order(study, "p02") == [1, 2, 0]


def test_shuffled_orders_are_permutations_that_vary_between_participants():
    study = Study(name="s", worlds=("a", "b", "c", "d"), order="shuffled")
    orders = {tuple(world_order(study, f"p{i}")) for i in range(200)}
    assert all(sorted(order) == [0, 1, 2, 3] for order in orders)
    assert len(orders) == 24  # every order of four worlds turns up among 200 participants
    assert world_order(study, "p5") == world_order(study, "p5")
