"""Computer participants for a study: Boltzmann experts written into the study's folder layout.

For tests and benchmarks of `careful study report`, and to try a study before running people:
each simulated participant is a Boltzmann expert (`irl_core.experts`) with its own beta, who
plays the study's protocol (its order, practice and main episodes per world) and whose files
carry the ``study`` header field, with the participant id as the player and the expert in the
header's ``input.expert``. One file per block: ``<out>/<ID>/<ID>-<block>-w<world_index>-<phase>.jsonl``,
``<block>`` counting the blocks in the order a participant plays them, so that name order is play order.
The same participants and seed write the same bytes.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np

from irl_core.recording_lines import StudyTag
from irl_core.experts import boltzmann_policy, expert_name, rollouts, session_header, write_rollouts
from irl_core.mdp import build_mdp
from irl_core.study import LoadedStudy, Phase, world_order


@dataclass(frozen=True)
class SimulatedParticipant:
    """A participant id, the beta of the Boltzmann expert who plays for it, and its seed."""

    participant: str
    beta: float
    seed: int


def simulated_participants(count: int, *, betas: tuple[float, float] = (0.2, 2.0), seed: int = 0,
                           prefix: str = "sim") -> list[SimulatedParticipant]:
    """`count` participants ``sim01``, ``sim02``, ... with betas spread evenly on a log scale over `betas`."""
    values = np.geomspace(*betas, count) if count > 1 else np.array([betas[0]])
    width = max(2, len(str(count)))
    return [SimulatedParticipant(f"{prefix}{i + 1:0{width}d}", float(beta), seed * 1_000_003 + i)
            for i, beta in enumerate(values.tolist())]


def write_simulated_participant(study: LoadedStudy, who: SimulatedParticipant, *,
                                phases: tuple[Phase, ...] = ("practice", "main")) -> list[Path]:
    """Write `who`'s whole protocol (or only `phases`) to their folder; returns the new files.

    Raises:
        FileExistsError: a file of theirs exists already (recordings are never overwritten).
        NotConverged: the expert's soft value iteration did not converge.
    """
    folder = study.participant_folder(who.participant)
    folder.mkdir(parents=True, exist_ok=True)
    targets = {"practice": study.study.practice_episodes, "main": study.study.episodes}
    written = []
    for world_index in world_order(study.study, who.participant):
        mdp = build_mdp(study.worlds[world_index])
        policy = boltzmann_policy(mdp, beta=who.beta)
        for phase_number, phase in enumerate(("practice", "main")):
            if phase not in phases or targets[phase] == 0:
                continue
            seed = int(np.random.SeedSequence([who.seed, world_index, phase_number]).generate_state(1)[0])
            player = expert_name("boltzmann", who.beta)
            tag = StudyTag(name=study.study.name, participant=who.participant, phase=phase, world_index=world_index)
            header = session_header(mdp, player=player, seed=seed).model_copy(
                update={"player": who.participant, "study": tag})
            path = folder / f"{who.participant}-{len(written)}-w{world_index}-{phase}.jsonl"
            result = rollouts(mdp, policy, episodes=targets[phase], seed=seed)
            written.append(write_rollouts(path, mdp, result, player=player, seed=seed, header=header))
    return written
