"""Computer participants for a study: Boltzmann experts or person-like players in the study's folder layout.

For tests and benchmarks of `careful study report`, and to try a study before running people:
each simulated participant is a Boltzmann expert (`irl_core.players.experts`) with its own beta, or a
person-like player (`irl_core.players.person_like`), who plays the study's protocol (its order, practice
and main episodes per world) and whose files carry the ``study`` header field, with the participant
id as the player and the expert in the header's ``input.expert``. One file per block:
``<out>/<ID>/<ID>-<block>-w<world_index>-<phase>.jsonl``, ``<block>`` counting the blocks in the
order a participant plays them, so that name order is play order.
With the study's ``calibration_block`` each first writes that motor calibration block, in a file of its own
tagged as their first block (targets on the first world's levels, produced by their own hand).
The same participants and seed write the same bytes. `write_person_like_study` writes a whole
study, its file included, of person-like participants and one reckless one (level 1 everywhere,
a quarter of moves random), for `careful study report` to be tried on.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np

from irl_core.play.motor_block import calibration_targets
from irl_core.players.experts import Chooser, boltzmann_policy, expert_name, rollouts, session_header, write_rollouts
from irl_core.players.person_like import motor_trials, person_like
from irl_core.recordings.lines import CalibrationTrial, SessionHeader, StudyTag
from irl_core.recordings.writer import RecordingWriter
from irl_core.studies.study import LoadedStudy, Phase, load_study, world_order
from irl_core.worlds.mdp import MDP, build_mdp

# The seed stream of a participant's calibration block, apart from their blocks' (world index, phase).
CALIBRATION_STREAM = 99


@dataclass(frozen=True)
class SimulatedParticipant:
    """A participant id, the beta of the Boltzmann expert who plays for it, and its seed; or, with a
    `kind` of `person_like.KINDS`, that person-like player (with its default parameters) instead."""

    participant: str
    beta: float | None
    seed: int
    kind: str = "boltzmann"

    def player(self, mdp: MDP) -> tuple[np.ndarray | Chooser, str]:
        """The policy or chooser that plays for this participant in `mdp`'s world, and its name."""
        if self.kind == "boltzmann":
            if self.beta is None:
                raise ValueError(f"{self.participant} is a Boltzmann participant without a beta")
            return boltzmann_policy(mdp, beta=self.beta), expert_name("boltzmann", self.beta)
        player = person_like(mdp, self.kind)
        return player.choose, player.player


def simulated_participants(count: int, *, betas: tuple[float, float] = (0.2, 2.0), seed: int = 0,
                           prefix: str = "sim") -> list[SimulatedParticipant]:
    """`count` participants ``sim01``, ``sim02``, ... with betas spread evenly on a log scale over `betas`."""
    values = np.geomspace(*betas, count) if count > 1 else np.array([betas[0]])
    width = max(2, len(str(count)))
    return [SimulatedParticipant(f"{prefix}{i + 1:0{width}d}", float(beta), seed * 1_000_003 + i)
            for i, beta in enumerate(values.tolist())]


def person_like_participants(count: int, *, kinds: tuple[str, ...] = ("loose", "timed", "hasty"),
                             reckless: int = 1, seed: int = 0, prefix: str = "p") -> list[SimulatedParticipant]:
    """`count` person-like participants ``p01``, ``p02``, ... taking `kinds` in turn, then `reckless`
    reckless ones (level 1 everywhere, a quarter of moves random), the last ids."""
    total = count + reckless
    width = max(2, len(str(total)))
    kind_of = [kinds[i % len(kinds)] for i in range(count)] + ["reckless"] * reckless
    return [SimulatedParticipant(f"{prefix}{i + 1:0{width}d}", None, seed * 1_000_003 + i, kind)
            for i, kind in enumerate(kind_of)]


def write_simulated_participant(study: LoadedStudy, who: SimulatedParticipant, *,
                                phases: tuple[Phase, ...] = ("practice", "main")) -> list[Path]:
    """Write `who`'s whole protocol (or only `phases`) to their folder; returns the new files.

    Raises:
        FileExistsError: a file of theirs exists already (recordings are never overwritten).
        NotConverged: the expert's (soft) value iteration did not converge.
    """
    folder = study.participant_folder(who.participant)
    folder.mkdir(parents=True, exist_ok=True)
    targets = {"practice": study.study.practice_episodes, "main": study.study.episodes}
    written: list[Path] = []
    order = world_order(study.study, who.participant)
    first: Phase = "practice" if study.study.practice_episodes else "main"
    if study.study.calibration_block and first in phases:  # the block comes before the first block
        written.append(_write_calibration_block(study, who, order[0], folder, phase=first))
    for world_index in order:
        mdp = build_mdp(study.grid_worlds[world_index])
        policy, player = who.player(mdp)
        for phase_number, phase in enumerate(("practice", "main")):
            if phase not in phases or targets[phase] == 0:
                continue
            seed = int(np.random.SeedSequence([who.seed, world_index, phase_number]).generate_state(1)[0])
            tag = StudyTag(name=study.study.name, participant=who.participant, phase=phase, world_index=world_index)
            header = session_header(mdp, player=player, seed=seed).model_copy(
                update={"player": who.participant, "study": tag})
            path = folder / f"{who.participant}-{len(written)}-w{world_index}-{phase}.jsonl"
            result = rollouts(mdp, policy, episodes=targets[phase], seed=seed)
            written.append(write_rollouts(path, mdp, result, player=player, seed=seed, header=header))
    return written


def _write_calibration_block(study: LoadedStudy, who: SimulatedParticipant, world_index: int, folder: Path, *,
                             phase: Phase) -> Path:
    """`who`'s motor calibration block, in a file of its own tagged as their first block, as a study writes it: the
    study's `calibration_block` targets on the first world's levels, each produced by their own hand (a Boltzmann
    expert's hand is exact)."""
    world = study.grid_worlds[world_index]
    mdp = build_mdp(world)
    seed = int(np.random.SeedSequence([who.seed, CALIBRATION_STREAM]).generate_state(1)[0])
    asked = np.array(calibration_targets(world.levels, study.study.calibration_block, seed=seed), dtype=np.int64)
    if who.kind == "boltzmann":
        trials, player = np.column_stack([asked, asked]), who.player(mdp)[1]
    else:
        person = person_like(mdp, who.kind)
        trials, player = motor_trials(person, asked, world.levels, np.random.default_rng(seed)), person.player
    tag = StudyTag(name=study.study.name, participant=who.participant, phase=phase, world_index=world_index)
    header = session_header(mdp, player=player, seed=seed).model_copy(update={"player": who.participant, "study": tag})
    return write_calibration_file(folder / f"{who.participant}-0-w{world_index}-{phase}.jsonl", header, trials)


def write_calibration_file(path: Path, header: SessionHeader, trials: np.ndarray) -> Path:
    """A new recording `path` of `header` and one ``calibration_trial`` line per (target, produced) of `trials`
    (n, 2), as a study's calibration block writes it; never overwriting."""
    with RecordingWriter(path, header) as writer:
        for target, produced in trials.tolist():
            writer.write_trial(CalibrationTrial(target=target, produced=produced))
    return path


def write_person_like_study(folder: str | Path, *, participants: int = 12, worlds: tuple[str, ...] = ("mud", "walls"),
                            episodes: int = 30, reckless: int = 1, seed: int = 0, calibration: int = 0) -> Path:
    """Write ``folder/study.toml`` and its data: `participants` person-like participants (loose, timed
    and hasty in turn) and `reckless` reckless ones, `episodes` main episodes per world and no practice,
    after a motor calibration block of `calibration` targets (0: none).
    Returns the study file, for ``careful study report``.

    Raises:
        FileExistsError: the study file exists already (nothing is overwritten).
    """
    path = Path(folder) / "study.toml"
    path.parent.mkdir(parents=True, exist_ok=True)
    entries = ", ".join(f'"{world}"' for world in worlds)
    with path.open("x", encoding="utf-8") as file:
        file.write(f'name = "person-like"\nworlds = [{entries}]\npractice_episodes = 0\nepisodes = {episodes}\n'
                   f'calibration_block = {calibration}\nout = "data"\n')
    study = load_study(path)
    for who in person_like_participants(participants, reckless=reckless, seed=seed):
        write_simulated_participant(study, who, phases=("main",))
    return path
