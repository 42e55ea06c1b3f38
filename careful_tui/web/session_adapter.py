"""One participant's way through a study in a browser: the play session the web server drives.

The server owns one `WebSession` per participant page. It drives the same play session as
`careful study run` (`irl_core.studies.flow.StudyFlow` and its blocks' `PlaySession`s: the
rules, the recordings in ``<out>/<ID>/``, resuming where the files say) and answers every call
with `view()`, what the page draws. The page sends only key presses and releases with their times
(`performance.now()`, milliseconds); every outcome (start cells, slips) is drawn here.

==============  ===============================================================
stage           what the page shows; the keys that act
==============  ===============================================================
instructions    the study's instructions and plan; space begins the next block (or the
                calibration block, when the study has one the participant has not done)
calibration     the motor calibration block: a level to make with the gauge visible
                ("hold until the gauge shows k, then let go"); arrows hold, space goes
                on to practice once every target has a trial
play            the board, the gauge and the score; arrows move (hold longer: more
                careful), space starts the next episode once one has ended
reach           a reach world's block (or, for "own" noise, its calibration block first): the
                field, the aim and the last endpoint; ``reach_press``/``reach_release`` time a
                simulated reach, ``reach_own`` hands over a pointer's reach (docs/reach.md);
                space goes on once the block is done
between         practice over, or a world done; space goes on
end             the end of the study (and, for a Prolific participant with a
                completion code, the address to go back to)
left            the participant left with q, or the page closed: what was played
                is kept, and opening the link again resumes where the files say
==============  ===============================================================

A hold is timed on the page from keydown to keyup and fed to the session as a press and an exact
release, so every step is ``hold_exact``; its level is `HoldProfile.level_for`, the game's own
timing function, on `browser_profile`: the terminal's scale (level 1 below 500 ms, and each
further 150 ms adds a level; a study file may choose another), so the two front ends pool. A press of another
arrow while one is held is ignored, and `cancel` (the window lost focus) drops the hold: no move.

This module is the one place the web server meets the play session: it turns the page's
milliseconds into the session's seconds, keeps to one arrow at a time, refuses a release that
is not a hold, and words the views for the page.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, replace
from typing import Any

from careful_tui.render.grid import format_chance, format_value
from careful_tui.render.session import legend_entries, outcome_text
from careful_tui.version import app_version
from irl_core.errors import KeyRefused
from irl_core.play.game import level_costs, level_slip_chances
from irl_core.play.hold import HoldProfile
from irl_core.play.motor_block import MOTOR_INTRO, MOTOR_TITLE, MotorBlock, result_words
from irl_core.play.reach_session import REACH_INTRO_OWN, ReachSession
from irl_core.play.session import Played, PlaySession
from irl_core.recordings.lines import ProlificTag
from irl_core.recordings.summary import outcome_code
from irl_core.studies import words
from irl_core.studies.flow import StudyFlow
from irl_core.studies.study import LoadedStudy, Protocol, read_protocol
from irl_core.support.plural import plural
from irl_core.support.safe_text import printable
from irl_core.worlds.mdp import DIRECTIONS
from irl_core.worlds.reach import ReachWorld
from irl_core.worlds.world import World

REACH_INTRO_POINTER = ("Point where to aim, then press and hold the mouse button for as long as the reach should "
                       "take and let go. The ring is where the reach may land: the longer you hold, the smaller it "
                       "gets, but time costs points.")
CALIBRATION_INTRO = ("Calibration: reach for the lone circle. Press on the start, move to the circle's centre and "
                     "let go, taking about the time asked each time. These reaches score nothing.")
# A hold longer than this is a key left down, not a choice; it is refused (no move).
LONGEST_HOLD_MS = 600_000.0
USER_AGENT_LIMIT = 400


def browser_profile(levels: int) -> HoldProfile:
    """The timing of a browser hold for a world of `levels` levels (the header records it): the
    terminal's level scale (`irl_core.play.hold.TAP_MS`), unless the study chooses another."""
    return HoldProfile(levels=levels)


def browser_study(study: LoadedStudy) -> LoadedStudy:
    """`study` as a browser plays it: a browser always times holds, so the study's terminal input mode
    does not apply."""
    return replace(study, study=study.study.model_copy(update={"input": "hold"}))


def input_header(profile: HoldProfile, user_agent: str) -> dict[str, object]:
    """The session header's ``input``: hold mode, timed exactly in a browser, and its level scale."""
    return {"mode": "hold", "front_end": "browser", "user_agent": user_agent[:USER_AGENT_LIMIT],
            "tap_ms": profile.tap_ms, "ms_per_level": profile.ms_per_level,
            "timing": "keydown to keyup, performance.now()"}


@dataclass
class _Held:
    key: str
    at_ms: float


class WebSession:
    """A participant from where their folder stands to the end of the study (see the module table).

    Args:
        study: the study.
        participant: a checked participant id (`irl_core.studies.study.check_participant`).
        user_agent: the browser's, for the header.
        prolific: Prolific's study and session ids, for the header, when the participant came that way.
        completion_url: where the end screen sends the participant, once every episode is on disk.
        say: receives a line for the experimenter's console when the participant starts, finishes a
            block and leaves.
        seed: fixes every block's seed (a test's); without it each block draws one.

    Raises (from the key calls):
        OSError, ValueError: the recording cannot be written; the participant can play no further.
    """

    def __init__(self, study: LoadedStudy, participant: str, *, user_agent: str = "",
                 prolific: ProlificTag | None = None, completion_url: str | None = None,
                 say: Callable[[str], None] = lambda line: None, seed: int | None = None) -> None:
        self.participant = participant
        self.user_agent = user_agent
        self.prolific = prolific
        self.completion_url = completion_url
        self.say = say
        self.study = browser_study(study)
        self.flow = StudyFlow(self.study, participant, seed=seed, app_version=app_version())
        levels = [world.levels for world in study.worlds if isinstance(world, World)]
        self.flow.profile = browser_profile(max(levels, default=1))  # each block's levels
        self.session: PlaySession | None = None
        self.reach: ReachSession | None = None  # a reach block, or an "own" noise world's calibration block
        self.reach_calibrating = False
        self.motor: MotorBlock | None = None
        self.stage = "end" if self.flow.stage == "end" else "instructions"
        self.held: _Held | None = None
        self.note = ""
        self.left = False
        for problem in self.protocol.problems:
            say(f"warning: {printable(problem, limit=300)}")

    @property
    def protocol(self) -> Protocol:
        return self.flow.protocol

    def tell(self, note: str) -> None:
        """A sentence for the participant in place of the session's message, until the next key."""
        self.note = note

    # ------------------------------------------------------------------ the page's keys

    def press(self, key: object, at_ms: object) -> None:
        """An arrow went down at `at_ms` (the page's clock): a hold starts, unless one is held."""
        key, at_ms = self._check(key, at_ms)
        if self._calibrating() and self.held is None:
            assert self.motor is not None
            self.held = _Held(key, at_ms)
            self.motor.press(key, at=0.0, repeat=False)
        elif self._live() and self.held is None:
            assert self.session is not None
            self.held = _Held(key, at_ms)
            self.note = ""
            # Each hold on a clock of its own from its press: the session's seconds then carry the
            # page's milliseconds whole (1150 / 1000 - 1 is 0.1499999..., a 150 ms hold at level 1).
            self._played(self.session.press(key, at=0.0, repeat=False))

    def release(self, key: object, at_ms: object) -> None:
        """An arrow came up at `at_ms`: the hold on it ends and its move is played."""
        key, at_ms = self._check(key, at_ms)
        held, session = self.held, self.session
        if held is not None and held.key == key and self._calibrating():
            self._release_trial(key, at_ms - held.at_ms)
            return
        if held is None or held.key != key or session is None:
            return
        self.held = None
        if not 0 <= at_ms - held.at_ms <= LONGEST_HOLD_MS:
            session.cancel_hold("held too long to be a move")
            return
        self._played(session.release(key, at=(at_ms - held.at_ms) / 1000))
        if session.view().all_played:
            # The block's last episode is on disk (fsynced at its end): close its file now.
            session.quit()

    def cancel(self) -> None:
        """The window lost focus (or the page could not send the release): the hold is dropped."""
        if self.held is not None and self.stage == "reach" and self.reach is not None:
            self.held = None
            self.reach.cancel_hold("the window lost focus")
        elif self.held is not None and self._calibrating():
            assert self.motor is not None
            self.held = None
            self.motor.cancel_hold()
        elif self.held is not None and self.session is not None:
            self.held = None
            self.session.cancel_hold("the window lost focus")

    def space(self) -> None:
        """Space: begin, go on, or start the next episode."""
        self.note = ""
        if self.stage == "reach":
            if self.reach is not None and self.reach.done and self.held is None:
                self._end_reach()
            return
        if self.stage == "instructions" and self._start_calibration():
            return
        if self.stage == "calibration":
            if self.motor is not None and self.motor.done and self.held is None:
                self.flow.calibration_ended()
                self.motor = None
                self._start_block()
        elif self.stage in ("instructions", "between"):
            self._start_block()
        elif self.stage == "play" and self.session is not None and self.held is None:
            if self.session.next_episode():
                self._end_block()

    def leave(self, why: str = "left") -> None:
        """q, or the page closed: a running episode with steps is recorded as quit, the file closed."""
        if self.left:
            return
        self.left, self.held = True, None
        if self.reach is not None:
            self.reach.quit()
        self.flow.quit()
        if self.flow.write_error is not None:
            self.say(f"{self.participant}: cannot close the recording ({printable(str(self.flow.write_error), limit=200)})")
        if self.stage != "end":
            self.stage = "left"
        done, total = read_protocol(self.study, self.participant).progress
        self.say(f"{self.participant}: {why} ({done} of {plural(total, 'episode')} done)")

    # ------------------------------------------------------------------ reach worlds

    def reach_press(self, aim: object, at_ms: object) -> None:
        """The pointer went down at `aim` (field units) at `at_ms`: a simulated reach aimed there starts being
        timed (its duration is the hold)."""
        session = self._reach_live("simulated")
        x, y = _pair(aim, "aim")
        at = _time(at_ms)
        if session is None or self.held is not None:
            return
        session.move_aim(x - session.aim[0], y - session.aim[1])
        self.held = _Held("space", at)
        self.note = ""
        session.press("space", at=0.0, repeat=False)

    def reach_release(self, at_ms: object) -> None:
        """The pointer came up at `at_ms`: the simulated reach is launched (or refused, in the session's words)."""
        at = _time(at_ms)
        session, held = self.reach, self.held
        if session is None or held is None or self.stage != "reach":
            return
        self.held = None
        if not 0 <= at - held.at_ms <= LONGEST_HOLD_MS:
            session.cancel_hold("held too long to be a reach")
            return
        session.release("space", at=(at - held.at_ms) / 1000)
        self._reach_written(session)

    def reach_own(self, endpoint: object, duration_ms: object) -> None:
        """A reach the page measured ("own" noise): where the pointer was when it ended and how long it took from
        leaving the start; refused in the session's words when outside the world's limits."""
        session = self._reach_live("own")
        point = _pair(endpoint, "endpoint")
        duration = _time(duration_ms)
        if session is None:
            return
        self.note = ""
        # The pointer's own reach has no aim apart from where it went: the endpoint is recorded as the aim too
        # (the scatter is the calibration block's law, not this trial's).
        session.launch_own(point, duration, aim=point)
        self._reach_written(session)

    def _reach_live(self, noise: str) -> ReachSession | None:
        session = self.reach
        if self.stage != "reach" or session is None or session.done or session.world.noise != noise:
            return None
        return session

    def _reach_written(self, session: ReachSession) -> None:
        if session.write_error is not None:
            raise session.write_error
        if self.reach_calibrating and session.done:
            # The block is whole on disk: its law is fitted and stored now, whether or not the participant goes on.
            session.quit()
            block = self.protocol.next_block
            assert block is not None
            fit = self.flow.reach_calibration_ended(block.world_index)
            if fit is not None:
                self.say(f"{self.participant}: finished the calibration block (a = {fit.spread.spread.a:.3g}, "
                         f"b = {fit.spread.spread.b:.3g})")

    def _start_reach(self) -> bool:
        """The next block's calibration block or reach block, if its world is a reach world."""
        block = self.protocol.next_block
        session = self.flow.reach_calibration()
        self.reach_calibrating = session is not None
        if session is None and block is not None:
            # A block made whole by a participant who left before its law was stored (a crash): stored now.
            self.flow.reach_calibration_ended(block.world_index)
            session = self.flow.next_reach_block()
        if session is None or block is None:
            return False
        recorder = session.recorder
        recorder.set_header(recorder.header.model_copy(update={
            "input": reach_input_header(session.world, self.user_agent), "prolific": self.prolific}))
        self.reach, self.stage = session, "reach"
        what = "the calibration block" if self.reach_calibrating else f"{block.phase}, {block.remaining} to go"
        self.say(f"{self.participant}: started world {block.position + 1} of {len(self.protocol.order)} "
                 f"({printable(session.world.name, limit=40)}), {what}")
        return True

    def _end_reach(self) -> None:
        session = self.reach
        assert session is not None
        session.quit()
        self.reach = None
        if self.reach_calibrating:
            self.reach_calibrating = False
            self._start_block()
            return
        stage = self.flow.reach_block_ended(session)
        self.stage = "end" if stage == "end" else "between"
        if self.stage == "end":
            self.say(f"{self.participant}: finished the study")

    def _reach_view(self) -> dict[str, Any]:
        session = self.reach
        assert session is not None
        now = session.view()
        world = now.world
        last = now.last
        deadline = (self.flow.reach_deadline(_study_world(self.protocol), now.trial - 1)
                    if self.reach_calibrating else None)
        return {
            "heading": session.options.heading,
            "field": list(world.field), "start": list(world.start),
            "regions": [{"symbol": printable(r.symbol), "centre": list(r.centre), "radius": r.radius,
                         "points": None if self.reach_calibrating else format_value(r.points)} for r in world.regions],
            "noise": world.noise, "spread": {"a": world.spread.a, "b": world.spread.b},
            "min_ms": world.min_ms, "max_ms": world.max_ms,
            "intro": (CALIBRATION_INTRO if self.reach_calibrating else
                      REACH_INTRO_OWN if world.noise == "own" else REACH_INTRO_POINTER),
            "calibration": self.reach_calibrating, "deadline_ms": deadline,
            "aim": list(now.aim), "trial": now.trial, "trials": now.trials, "done": now.done,
            "score": format_value(now.score),
            "last": None if last is None else {
                "aim": list(last.aim), "endpoint": list(last.endpoint), "regions": list(last.regions),
                "reward": format_value(last.reward), "duration_ms": last.duration_ms},
            "message": self.note or now.message.text, "tone": now.message.kind,
        }

    # ------------------------------------------------------------------ the flow

    def _calibrating(self) -> bool:
        return self.stage == "calibration" and self.motor is not None and not self.motor.done

    def _start_calibration(self) -> bool:
        """The calibration block, if the study has one not yet done: its trials' file gets the browser's header."""
        motor = self.flow.calibration()
        if motor is None:
            return False
        recorder = motor.recorder
        recorder.set_header(recorder.header.model_copy(update={
            "input": input_header(motor.profile, self.user_agent), "prolific": self.prolific}))
        self.motor, self.stage = motor, "calibration"
        self.say(f"{self.participant}: started the calibration block ({plural(len(motor.targets), 'target')})")
        return True

    def _release_trial(self, key: str, held_ms: float) -> None:
        """A calibration hold ended after `held_ms`: its trial is written (or it is refused as too long)."""
        assert self.motor is not None
        self.held = None
        if not 0 <= held_ms <= LONGEST_HOLD_MS:
            self.motor.cancel_hold()
            return
        self.motor.release(key, at=held_ms / 1000)
        if self.motor.write_error is not None:
            raise self.motor.write_error
        if self.motor.done:
            self.say(f"{self.participant}: finished the calibration block")

    def _live(self) -> bool:
        return self.stage == "play" and self.session is not None and self.session.game.live

    def _check(self, key: object, at_ms: object) -> tuple[str, float]:
        """The page's key and time, as they came, once they are an arrow and a time (else KeyRefused)."""
        if not (isinstance(key, str) and key in DIRECTIONS):
            raise KeyRefused(f"not an arrow: {printable(str(key), limit=20)!r}")
        return key, _time(at_ms)

    def _played(self, played: Played) -> None:
        assert self.session is not None
        if played.stopped:
            error = self.session.write_error
            assert error is not None, "a stopped session says why"
            raise error

    def _start_block(self) -> None:
        if self._start_reach():
            return
        session = self.flow.next_block()
        if session is None:
            self.stage = "end"
            return
        block = self.protocol.next_block
        assert block is not None
        recorder = session.recorder
        recorder.set_header(recorder.header.model_copy(update={
            "input": input_header(session.profile, self.user_agent), "prolific": self.prolific}))
        session.start()
        self.session, self.stage = session, "play"
        self.say(f"{self.participant}: started world {block.position + 1} of {len(self.protocol.order)} "
                 f"({printable(session.world.name, limit=40)}), {block.phase}, episode {block.done + 1} of {block.target}")

    def _end_block(self) -> None:
        assert self.session is not None
        self.session.quit()
        finished = self.protocol.next_block
        stage = self.flow.block_ended()
        self.session = None
        if finished is not None:
            self.say(f"{self.participant}: finished world {finished.position + 1} of {len(self.protocol.order)}, "
                     f"{finished.phase}")
        self.stage = "end" if stage == "end" else "between"
        if self.stage == "end":
            self.say(f"{self.participant}: finished the study")

    # ------------------------------------------------------------------ what the page draws

    def view(self) -> dict[str, Any]:
        """Everything the page draws now, as JSON-ready data; every text is plain text."""
        view: dict[str, Any] = {"stage": self.stage, "title": printable(self.study.study.name, limit=80),
                                "participant": self.participant}
        if self.stage == "calibration":
            view["calibration"] = self._calibration_view()
            held = [["←↑→↓", "hold until the gauge shows the level, then let go"]]
            calibration = view["calibration"]
            view["keys"] = ([["space", calibration["begin"]]] if calibration["done"] else held) + [["q", "leave"]]
        elif self.stage == "reach":
            view["reach"] = self._reach_view()
            if view["reach"]["done"]:
                keys = [["space", "go on"]]
            elif view["reach"]["noise"] == "own":
                keys = [["mouse", "press on the start, move, let go where the reach ends"]]
            else:
                keys = [["mouse", "point to aim; hold the button for the reach's time, let go"]]
            view["keys"] = keys + [["q", "leave"]]
        elif self.stage == "play":
            view["play"] = self._play_view()
            if self._live():
                keys = [["←↑→↓", "hold: move, longer is more careful"]]
            else:
                keys = [["space", "go on" if view["play"]["all_played"] else "next episode"]]
            view["keys"] = keys + [["q", "leave"]]
        else:
            view["paragraphs"] = _paragraphs(self._screen_words())
            view["keys"] = [] if self.stage in ("end", "left") else [["space", "begin" if self.stage == "instructions"
                                                                       else "go on"], ["q", "leave"]]
        if self.stage == "end" and self.completion_url is not None:
            view["complete_url"] = self.completion_url
        return view

    def _screen_words(self) -> list[words.Paragraph]:
        if self.stage == "instructions":
            # The browser times every hold, so the plan words it as hold input whatever the study's input.
            return words.opening(self.protocol, input_name="hold", experimenter=False)
        if self.stage == "between":
            assert self.flow.finished is not None
            return words.between(self.protocol, self.flow.finished)
        protocol = read_protocol(self.study, self.participant)
        if self.stage == "end":
            return words.end(protocol, show_folder=False, to_prolific=self.completion_url is not None)
        return words.left(protocol)

    def _calibration_view(self) -> dict[str, Any]:
        motor = self.motor
        assert motor is not None
        now = motor.view()
        block = self.protocol.next_block
        assert block is not None, "the calibration block comes before a block"
        world = self.protocol.world(block)
        return {
            "heading": f"{MOTOR_TITLE} · {min(now.number, now.count)} of {now.count}",
            "intro": MOTOR_INTRO, "instruction": now.instruction, "target": now.target, "done": now.done,
            "begin": now.begin,
            "last": None if now.last is None else result_words(now.last),
            "levels": [{"level": c, "cost": format_value(-cost) if cost else "0", "slip": format_chance(p)}
                       for c, (cost, p) in enumerate(zip(level_costs(world), level_slip_chances(world)), start=1)],
            "timing": {"tap_ms": motor.profile.tap_ms, "ms_per_level": motor.profile.ms_per_level,
                       "levels": motor.profile.levels},
        }

    def _play_view(self) -> dict[str, Any]:
        session = self.session
        assert session is not None
        now, world, profile = session.view(), session.world, session.profile
        move = now.last_move
        message = self.note or f"{now.message.lead}{now.message.text}"
        view: dict[str, Any] = {
            "heading": session.options.heading,
            "rows": [printable(row) for row in world.layout.splitlines()],
            # The terminal's legend too (`legend_entries`): the same words whichever front end a participant uses.
            "legend": [[entry.symbol, entry.name, entry.reward, entry.ends]
                       for entry in legend_entries(world, show_rewards=session.options.show_rewards)],
            # A time world shows no levels: the page draws no gauge, and the held time only with show_hold.
            "care": world.care, "show_hold": world.care == "time" and world.show_hold,
            "levels": [] if world.care == "time" else [
                {"level": c, "cost": format_value(-cost) if cost else "0", "slip": format_chance(p)}
                for c, (cost, p) in enumerate(zip(level_costs(world), level_slip_chances(world)), start=1)],
            "timing": {"tap_ms": profile.tap_ms, "ms_per_level": profile.ms_per_level,
                       "levels": profile.levels},
            "player": list(now.cell) if now.cell is not None else None,
            "live": now.live,
            "episode": f"{session.names.word} {session.names.number(now.episode)}",
            "step": now.step, "max_steps": world.max_steps,
            "score": format_value(now.score), "score_low": now.score < world.initial_score,
            "last_move": None if move is None else {
                "direction": move.step.direction, "level": move.step.carefulness, "hold_ms": move.step.hold_ms,
                "slipped": move.slipped, "realised": move.realised,
                "from": list(move.step.state), "to": list(move.step.next_state)},
            "message": message, "all_played": now.all_played,
        }
        if not now.live and now.last_end is not None:
            view["end"] = {"text": outcome_text(now.last_end), "code": outcome_code(now.last_end),
                           "score": format_value(now.last_end.score)}
        return view


def _pair(value: object, name: str) -> tuple[float, float]:
    """A point the page sent: two finite numbers (else KeyRefused)."""
    if not (isinstance(value, list) and len(value) == 2
            and all(type(x) in (int, float) and abs(x) < 1e9 for x in value)):  # NaN fails abs(x) < 1e9
        raise KeyRefused(f"{name} must be a pair of numbers [x, y]")
    return float(value[0]), float(value[1])


def _time(value: object) -> float:
    """A time the page sent, in ms (else KeyRefused)."""
    # bool is an int to Python (true was taken as 1 ms), and a 1,900-digit int overflows a float:
    # the type first, then the range (int and float compare exactly), only then arithmetic.
    if type(value) not in (int, float) or not 0 <= value < 1e12:  # type: ignore[operator]
        raise KeyRefused("a key's time must be a number of milliseconds")
    return float(value)  # type: ignore[arg-type]


def _study_world(protocol: Protocol) -> ReachWorld:
    block = protocol.next_block
    assert block is not None
    world = protocol.study_world(block)
    assert isinstance(world, ReachWorld)
    return world


def reach_input_header(world: ReachWorld, user_agent: str) -> dict[str, object]:
    """A browser reach recording's ``input``: how its durations (and, with "own" noise, endpoints) were taken."""
    timing = ("from the pointer leaving the start to the button coming up, event timestamps (performance.now())"
              if world.noise == "own" else "button down to button up, event timestamps (performance.now())")
    return {"mode": "pointer", "front_end": "browser", "user_agent": user_agent[:USER_AGENT_LIMIT], "timing": timing}


def _paragraphs(paragraphs: list[words.Paragraph]) -> list[dict[str, str]]:
    """A screen's words as the page's paragraphs: plain text, each with the tone of its first span (the page
    draws one tone a paragraph)."""
    return [{"text": "".join(span.text for span in paragraph), "tone": paragraph[0].tone}
            for paragraph in paragraphs if "".join(span.text for span in paragraph).strip()]
