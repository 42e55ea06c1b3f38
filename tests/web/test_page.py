"""The page in headless Chromium (Debian's, driven by Playwright): holds timed from keydown to
keyup, a participant from a link to the end, a Prolific participant to the completion address,
a reload mid-episode, a second page, focus lost mid-hold, a phone, texts shown as text."""

from __future__ import annotations

import re
import time

from web.conftest import recorded_lines

from careful_tui.web.session_adapter import browser_profile
from irl_core.studies.study import read_protocol

TIMEOUT_S = 10
# Case-sensitive and from the start: "Practice episode 1 of 1" must not match.
MAIN_EPISODE = re.compile(r"^Episode 1 of 1")


def steps_of(live, participant: str) -> list[dict]:
    folder = live.study.participant_folder(participant)
    return [line for line in recorded_lines(folder) if line["kind"] == "step"] if folder.exists() else []


def wait_for(condition, what: str):
    deadline = time.monotonic() + TIMEOUT_S
    while time.monotonic() < deadline:
        value = condition()
        if value:
            return value
        time.sleep(0.02)
    raise AssertionError(f"timed out waiting for {what}")


def open_and_begin(page, url: str) -> None:
    page.goto(url)
    page.wait_for_selector("#text:not([hidden])")
    page.keyboard.press(" ")
    page.wait_for_selector("#play:not([hidden])")


def hold(page, key: str, ms: float) -> None:
    page.keyboard.down(key)
    page.wait_for_timeout(ms)
    page.keyboard.up(key)


def tap_to_goal(page, live, participant: str) -> None:
    """Four short moves right: the hall's goal (waiting for each to be recorded)."""
    for _ in range(4):
        before = len(steps_of(live, participant))
        hold(page, "ArrowRight", 30)
        wait_for(lambda: len(steps_of(live, participant)) > before, "a move to be recorded")
    page.wait_for_selector("#status .end-G")


def timed_hold(page, key: str, ms: float) -> tuple[float, float]:
    """Hold `key` for `ms` (keyboard.down, wait, keyboard.up); returns the shortest and the longest
    the hold can have been in the browser, from when each call began and returned."""
    t0 = time.monotonic()
    page.keyboard.down(key)
    t1 = time.monotonic()
    time.sleep(ms / 1000)
    t2 = time.monotonic()
    page.keyboard.up(key)
    t3 = time.monotonic()
    return (t2 - t1) * 1000, (t3 - t0) * 1000


def test_holds_are_recorded_to_within_20_ms_exact_at_the_timings_level(page, live_server):
    """Every hold is recorded inside the window the test's calls allow (when each began and
    returned); on a busy machine those calls can be late, so a hold recorded more than 20 ms
    off its script is tried again, at most 5 times."""
    open_and_begin(page, live_server.link("p001"))
    on_time = {}
    for ms in (50, 300, 800):
        for _ in range(5):
            before = len(steps_of(live_server, "p001"))
            shortest, longest = timed_hold(page, "ArrowUp", ms)  # up bumps the hall's top wall: the episode goes on
            step = wait_for(lambda: steps_of(live_server, "p001")[before:], f"the {ms} ms hold to be recorded")[0]
            assert shortest - 2 <= step["hold_ms"] <= longest + 2
            on_time[ms] = (step, shortest, longest)
            if abs(step["hold_ms"] - ms) <= 20:
                break
    # Within 20 ms of the script whenever the driver kept to it (its calls began and returned within 20 ms of
    # the script); on a busy machine they can be late in every try, and then the window above is the check.
    for ms, (step, shortest, longest) in on_time.items():
        kept_to_script = ms - 20 <= shortest and longest <= ms + 20
        assert abs(step["hold_ms"] - ms) <= 20 or not kept_to_script, (ms, step["hold_ms"], shortest, longest)
    recorded = steps_of(live_server, "p001")
    assert all(step["hold_exact"] for step in recorded)
    assert [step["carefulness"] for step in recorded] == [browser_profile(14).level_for(s["hold_ms"]) for s in recorded]
    # The terminal's scale: under 500 ms is a tap, 800 ms is level 4 (as in `careful play`).
    assert [browser_profile(14).level_for(ms) for ms in (50, 300, 800)] == [1, 1, 4]
    page.locator("#hold-info", has_text="last move").wait_for()


def test_a_link_participant_goes_through_instructions_practice_main_and_the_end(page, live_server):
    dialogs = []
    page.on("dialog", lambda dialog: (dialogs.append(dialog.message), dialog.dismiss()))
    page.goto(live_server.link("p002"))
    page.wait_for_selector("#text:not([hidden])")
    text = page.inner_text("#text")
    assert "<img src=x onerror=alert(1)> is text." in text and "web <b>pilot</b>" in text
    assert page.locator("#text img, #text b, script:not([src])").count() == 0
    page.keyboard.press(" ")
    page.wait_for_selector("#play:not([hidden])")
    assert "Practice episode 1 of 1" in page.inner_text("#status")
    assert "hall <i>of</i>" in page.inner_text("#heading")
    assert page.locator("#gauge .num").count() == 14
    tap_to_goal(page, live_server, "p002")
    page.keyboard.press(" ")
    page.wait_for_selector("text=Practice is over.")
    page.keyboard.press(" ")
    page.locator("#status strong", has_text=MAIN_EPISODE).wait_for()
    tap_to_goal(page, live_server, "p002")
    page.keyboard.press(" ")
    page.wait_for_selector("text=That is the end of the study. Thank you!")
    assert read_protocol(live_server.study, "p002").finished
    assert dialogs == []


def test_a_prolific_participant_reaches_the_completion_address_only_after_the_last_episode_is_on_disk(page, live_server):
    reached = []

    def completion(route):
        # What the files say at the moment the page navigates away.
        reached.append((route.request.url, read_protocol(live_server.study, "prolific-PPX1").finished))
        route.fulfill(status=200, content_type="text/html", body="<p>Prolific</p>")

    page.route("https://app.prolific.com/**", completion)
    open_and_begin(page, f"{live_server.url}/?PROLIFIC_PID=PPX1&STUDY_ID=st1&SESSION_ID=se1")
    tap_to_goal(page, live_server, "prolific-PPX1")
    page.keyboard.press(" ")
    page.wait_for_selector("text=Practice is over.")
    assert reached == []
    page.keyboard.press(" ")
    page.locator("#status strong", has_text=MAIN_EPISODE).wait_for()
    tap_to_goal(page, live_server, "prolific-PPX1")
    assert reached == []
    page.keyboard.press(" ")
    page.wait_for_url("https://app.prolific.com/**", timeout=TIMEOUT_S * 1000)
    assert reached == [("https://app.prolific.com/submissions/complete?cc=C0DE-42", True)]
    header = recorded_lines(live_server.study.participant_folder("prolific-PPX1"))[0]
    assert header["prolific"] == {"study_id": "st1", "session_id": "se1"}
    assert "Chrome" in header["input"]["user_agent"]


def test_a_reload_mid_episode_resumes_where_the_files_say(page, live_server):
    open_and_begin(page, live_server.link("p001"))
    tap_to_goal(page, live_server, "p001")
    page.keyboard.press(" ")
    page.wait_for_selector("text=Practice is over.")
    page.keyboard.press(" ")
    page.locator("#status strong", has_text=MAIN_EPISODE).wait_for()
    hold(page, "ArrowRight", 30)
    wait_for(lambda: len(steps_of(live_server, "p001")) == 5, "the main episode's first move")
    page.reload()
    page.wait_for_selector("text=Welcome back: 1 of 2 episodes are done.")
    page.keyboard.press(" ")
    page.wait_for_selector("#play:not([hidden])")
    assert "step 0/200" in page.inner_text("#status")
    tap_to_goal(page, live_server, "p001")
    page.keyboard.press(" ")
    page.wait_for_selector("text=That is the end of the study. Thank you!")
    outcomes = sorted((line["episode"], line["outcome"]) for line in recorded_lines(live_server.study.participant_folder("p001"))
                      if line["kind"] == "episode_end")
    assert outcomes == [(0, "quit"), (0, "terminal"), (1, "terminal")]


def test_a_second_page_for_the_same_participant_is_refused_while_the_first_plays(browser, page, live_server):
    open_and_begin(page, live_server.link("p001"))
    hold(page, "ArrowRight", 30)
    other = browser.new_context(viewport={"width": 1280, "height": 800}).new_page()
    other.goto(live_server.link("p001"))
    other.wait_for_selector("text=The study is open somewhere else")
    assert "another tab" in other.inner_text("#notice")
    other.keyboard.press(" ")
    hold(other, "ArrowRight", 30)
    hold(page, "ArrowRight", 30)
    wait_for(lambda: len(steps_of(live_server, "p001")) == 2, "the first page's second move")
    time.sleep(0.2)
    assert [step["t"] for step in steps_of(live_server, "p001")] == [0, 1]
    assert len(list(live_server.study.participant_folder("p001").glob("*.jsonl"))) == 1
    other.context.close()


def test_focus_lost_mid_hold_moves_nothing(page, live_server):
    open_and_begin(page, live_server.link("p001"))
    page.keyboard.down("ArrowRight")
    page.wait_for_timeout(200)
    page.evaluate("window.dispatchEvent(new FocusEvent('blur'))")
    page.wait_for_timeout(100)
    page.keyboard.up("ArrowRight")
    page.wait_for_selector("text=Move cancelled (the window lost focus).")
    hold(page, "ArrowUp", 30)
    wait_for(lambda: steps_of(live_server, "p001"), "the next move")
    assert [step["direction"] for step in steps_of(live_server, "p001")] == ["up"]


def test_a_phone_is_told_the_study_needs_a_keyboard(browser, live_server):
    context = browser.new_context(viewport={"width": 390, "height": 844}, is_mobile=True, has_touch=True)
    phone = context.new_page()
    phone.goto(live_server.link("p001"))
    phone.wait_for_selector("text=This study needs a keyboard")
    phone.wait_for_timeout(300)
    assert len(live_server.seats) == 0  # it never claimed the participant
    context.close()
