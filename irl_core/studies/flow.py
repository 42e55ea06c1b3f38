"""A participant's way through a study, for any front end: instructions, blocks, between, end.

The flow shows the study's instructions first (or the end, for a participant who has finished).
Then, for the next block of the participant's protocol (a world's practice or main episodes,
`irl_core.studies.study.read_protocol`), `next_block` makes a `PlaySession` that plays the block's
remaining episodes into a new file of the participant's folder, the file's header carrying the
block's `study` tag and its episode numbers continuing the block's. When the front end says the
block is over (`block_ended`), the protocol is read again from the folder, so what comes next is
always what the files say: a note when practice ends and the main episodes begin, a screen
between worlds, and the end when nothing is left. Resuming is the same: a participant run again
goes on where the files say, and an interrupted episode is played again. A calibration made in
a block carries over to the next blocks, on each block's world's levels.

A study with a motor calibration block (``calibration_block = N``) asks its targets after the
instructions and before the first block: `calibration` makes the `MotorBlock` (its trials go to
a file of their own, the participant's first of the study, tagged as the first block), and
`calibration_ended` moves on. A participant who left mid-block is asked the rest.
"""

from __future__ import annotations

import json
import secrets
import time
from dataclasses import replace
from typing import Literal

from irl_core.play.hold import Clock, HoldProfile
from irl_core.play.motor_block import MotorBlock, calibration_targets
from irl_core.play.reach_session import ReachOptions, ReachSession, reach_header
from irl_core.play.session import PlayOptions, PlaySession, new_session, session_header
from irl_core.reach.calibration import SPREAD_FILE, CalibrationFit, calibration_schedule, calibration_world, fit_calibration
from irl_core.recordings.writer import SessionRecorder
from irl_core.studies.study import Block, LoadedStudy, Protocol, read_participant, read_protocol
from irl_core.support.safe_files import built_beside
from irl_core.support.safe_text import cut, printable
from irl_core.worlds.reach import ReachWorld

Stage = Literal["instructions", "calibration", "practice_over", "next_world", "end"]
# A block's heading is shown in this much; the study's name takes at most STUDY_NAME_LIMIT of it.
HEADING_LIMIT, STUDY_NAME_LIMIT = 60, 20
STUDY_COMMAND = "careful study run"


def block_heading(protocol: Protocol, block: Block) -> str:
    """ "pilot · world 1 of 2 (paper) · practice", at most `HEADING_LIMIT` characters: a long
    study or world name is cut, never the place and the phase."""
    name = cut(printable(protocol.study.study.name), STUDY_NAME_LIMIT, say_length=False)
    place = f" · world {block.position + 1} of {len(protocol.order)} ("
    phase = f") · {block.phase}"
    room = max(8, HEADING_LIMIT - len(name) - len(place) - len(phase))
    world = cut(printable(protocol.study_world(block).name), room, say_length=False)
    return f"{name}{place}{world}{phase}"


def block_options(protocol: Protocol, block: Block, participant: str, profile: HoldProfile | None) -> PlayOptions:
    """How a block plays: the study's input mode, `profile` (a calibration carried over) on the
    block's world's levels and the study's level scale, its title, its remaining episodes and how
    they are counted."""
    world = protocol.world(block)
    study = protocol.study.study
    return PlayOptions(
        input_mode=study.input,
        profile=replace(profile or HoldProfile(), levels=world.levels, tap_ms=study.tap_ms,
                        ms_per_level=study.ms_per_level),
        player=participant,
        heading=block_heading(protocol, block),
        command=STUDY_COMMAND,
        episodes=block.remaining,
        episodes_done=block.done,
        episode_word="Practice episode" if block.phase == "practice" else "Episode",
        show_rewards=study.show_rewards,
    )


class StudyFlow:
    """`participant` through `study`, from where their folder stands.

    Args:
        clock: the sessions' clock.
        seed: every block's seed (a test's); None draws one per block.
        app_version: the version recorded in each file's header.

    Attributes:
        stage: what shows now: ``instructions``, ``calibration``, ``practice_over``, ``next_world`` or ``end``.
        protocol: where the participant stands, as the folder says (read again after each block).
        finished: the block played last (None before any).
        sessions: every block's session, in order (what was recorded, any write error).
    """

    def __init__(self, study: LoadedStudy, participant: str, *, clock: Clock = time.monotonic,
                 seed: int | None = None, app_version: str) -> None:
        self.study = study
        self.participant = participant
        self.clock = clock
        self.seed = seed
        self.app_version = app_version
        self.protocol = read_protocol(study, participant)
        self.stage: Stage = "end" if self.protocol.finished else "instructions"
        self.finished: Block | None = None
        self.sessions: list[PlaySession] = []
        self.profile: HoldProfile | None = None
        self._playing: Block | None = None
        self.motor: MotorBlock | None = None

    def calibration(self) -> MotorBlock | None:
        """The motor calibration block's remaining targets, for the front end to play before
        `next_block`; None when the study has none or the participant's files hold them all."""
        left = self.protocol.calibration_left
        block = self.protocol.next_block
        if left <= 0 or block is None:
            return None
        seed = secrets.randbelow(2**32) if self.seed is None else self.seed
        options = block_options(self.protocol, block, self.participant, self.profile)
        world = self.protocol.world(block)
        header = session_header(world, options=options, seed=seed, app_version=self.app_version,
                                study=self.protocol.tag(block))
        assert options.profile is not None, "block_options always sets the profile"
        self.motor = MotorBlock(calibration_targets(world.levels, left, seed=seed),
                                SessionRecorder(self.protocol.folder, header), input_mode_name=options.input_mode,
                                profile=options.profile, clock=self.clock,
                                done_before=self.protocol.calibration_trials, next_phase=block.phase)
        self.stage = "calibration"
        return self.motor

    def calibration_ended(self) -> None:
        """The calibration block's targets were played (or it stopped): read the folder again."""
        if self.motor is not None:
            self.motor.close()
        self.protocol = read_protocol(self.study, self.participant)

    def next_block(self) -> PlaySession | None:
        """The next block's session, for the front end to play (`start` it); None when nothing is
        left, and the stage is then ``end``."""
        block = self.protocol.next_block
        if block is None:
            self.stage = "end"
            return None
        seed = secrets.randbelow(2**32) if self.seed is None else self.seed
        session = new_session(self.protocol.world(block), out=self.protocol.folder, seed=seed,
                              options=block_options(self.protocol, block, self.participant, self.profile),
                              clock=self.clock, app_version=self.app_version, study=self.protocol.tag(block),
                              first_episode=block.next_episode)
        self.sessions.append(session)
        self._playing = block
        return session

    def next_reach_block(self) -> ReachSession | None:
        """The next block's session when its world is a reach world (None otherwise): a `ReachSession` of the
        block's remaining trials, its file tagged as the block's (docs/reach.md)."""
        block = self.protocol.next_block
        if block is None or not isinstance(world := self.protocol.study_world(block), ReachWorld):
            return None
        session = self._reach_session(world, block, trials=block.remaining,
                                      heading=block_heading(self.protocol, block))
        self._playing = block
        return session

    def reach_calibration(self) -> ReachSession | None:
        """The calibration block of the next block's reach world with "own" noise, its remaining reaches (to the
        lone target, `irl_core.reach.calibration`); None when there is none to make."""
        left = self.protocol.reach_calibration_left
        block = self.protocol.next_block
        if left <= 0 or block is None or not isinstance(world := self.protocol.study_world(block), ReachWorld):
            return None
        return self._reach_session(calibration_world(world), block, trials=left,
                                   heading=f"{block_heading(self.protocol, block).rsplit(' · ', 1)[0]} · calibration")

    def reach_deadline(self, world: ReachWorld, trial: int) -> float:
        """The deadline (ms) asked of the calibration block's `trial`-th reach (0-based) still to make."""
        schedule = calibration_schedule(world, self.study.study.calibration_reaches)
        done = len(schedule) - self.protocol.reach_calibration_left
        return schedule[min(done + trial, len(schedule) - 1)]

    def reach_calibration_ended(self, world_index: int) -> CalibrationFit | None:
        """The calibration block of the world at `world_index` was left or made whole: the folder is read again
        and, once whole, the spread law fitted from every calibration reach of the world is written beside the
        recordings and returned; None when the block is not whole, the world has no such block, or its law was
        stored before (never written over)."""
        self.protocol = read_protocol(self.study, self.participant)
        world = self.study.worlds[world_index]
        path = self.protocol.folder / SPREAD_FILE.format(index=world_index)
        if (self.protocol.reach_calibration_left or not isinstance(world, ReachWorld) or world.noise != "own"
                or path.exists()):
            return None
        lone = calibration_world(world)
        steps = [step for _, reach in read_participant(self.study, self.participant).reaches if reach.world == lone
                 for step in reach.steps]
        fit = fit_calibration(world, [step.duration_ms for step in steps], [step.endpoint for step in steps])
        with built_beside(path) as temporary:
            temporary.write_text(json.dumps(fit.to_json(), indent=1) + "\n", encoding="utf-8")
        return fit

    def _reach_session(self, world: ReachWorld, block: Block, *, trials: int, heading: str) -> ReachSession:
        seed = secrets.randbelow(2**32) if self.seed is None else self.seed
        header = reach_header(world, player=self.participant, seed=seed, app_version=self.app_version)
        header = header.model_copy(update={"study": self.protocol.tag(block)})
        options = ReachOptions(player=self.participant, trials=trials, heading=heading, command=STUDY_COMMAND)
        return ReachSession(world, SessionRecorder(self.protocol.folder, header), seed=seed, options=options,
                            clock=self.clock)

    def reach_block_ended(self, session: ReachSession) -> Stage:
        """A reach block's session is done or left: its file is closed and the folder read again."""
        session.quit()
        block, self._playing = self._playing, None
        assert block is not None, "reach_block_ended without next_reach_block"
        return self._after(block)

    def block_ended(self) -> Stage:
        """The block's session played its episodes: read where the participant stands now."""
        block, self._playing = self._playing, None
        assert block is not None, "block_ended without next_block"
        self.profile = self.sessions[-1].profile
        return self._after(block)

    def _after(self, block: Block) -> Stage:
        """Where the participant stands once `block` was played: the folder read again."""
        self.protocol = read_protocol(self.study, self.participant)
        self.finished = block
        if self.protocol.finished:
            self.stage = "end"
        else:
            following = self.protocol.next_block
            practice_over = (following is not None and following.world_index == block.world_index
                             and following.phase == "main")
            self.stage = "practice_over" if practice_over else "next_world"
        return self.stage

    def quit(self) -> None:
        """End the running block's episode as ``quit`` and close its file (safe to call more than once)."""
        for session in self.sessions:
            session.quit()
        if self.motor is not None:
            self.motor.close()

    @property
    def write_error(self) -> OSError | ValueError | None:
        """The first block's write failure, if any stopped one."""
        errors = [s.write_error for s in self.sessions] + [self.motor.write_error if self.motor else None]
        return next((error for error in errors if error is not None), None)
