"""Kitty keyboard-protocol sequences: the decoder, the parser and the driver."""

from __future__ import annotations

import asyncio
import json
import os
import select
import subprocess
import sys
import time
from pathlib import Path

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from textual import events
from textual._keyboard_protocol import FUNCTIONAL_KEYS
from textual._xterm_parser import XTermParser
from textual.app import App
from textual.message import Message

from careful_tui.keys.kitty import (
    KeyRelease,
    KittyDriver,
    KittyKey,
    KittyKeyEvent,
    KittyParser,
    key_repeat,
    parse_kitty_key,
)

RELEASE_UP = "\x1b[1;1:3A"
REPEAT_UP = "\x1b[1;1:2A"
RELEASE_A = "\x1b[97;1:3u"
RELEASE_KP0 = "\x1b[57399;1:3u"
BAD_EVENT_TYPE = "\x1b[1;1:9A"


def feed(data: str, *, chunk: int | None = None) -> list[Message]:
    """Every message a fresh KittyParser yields for `data`, fed whole or in chunks."""
    parser = KittyParser()
    if chunk is None:
        return list(parser.feed(data))
    messages: list[Message] = []
    for start in range(0, len(data), chunk):
        messages += parser.feed(data[start : start + chunk])
    return messages


def described(messages: list[Message]) -> list[tuple[str, str, bool | None]]:
    """(kind, key, repeat) for each key message, to compare lists at a glance."""
    out = []
    for message in messages:
        if isinstance(message, KeyRelease):
            out.append(("release", message.key, None))
        elif isinstance(message, events.Key):
            out.append(("key", message.key, key_repeat(message)))
    return out


# --- parse_kitty_key ----------------------------------------------------------------------


@pytest.mark.parametrize(
    ("sequence", "key", "event_type", "modifiers"),
    [
        ("\x1b[A", "up", "press", set()),
        ("\x1b[B", "down", "press", set()),
        ("\x1b[1;1:1C", "right", "press", set()),
        ("\x1b[1;1:2D", "left", "repeat", set()),
        (REPEAT_UP, "up", "repeat", set()),
        (RELEASE_UP, "up", "release", set()),
        ("\x1b[1;5:3A", "ctrl+up", "release", {"ctrl"}),
        ("\x1b[1;2:2B", "shift+down", "repeat", {"shift"}),
        ("\x1b[1;65:3A", "up", "release", {"caps_lock"}),
        (RELEASE_A, "a", "release", set()),
        ("\x1b[97;2;65u", "A", "press", {"shift"}),
        ("\x1b[97:65;2:3u", "shift+a", "release", {"shift"}),
        (RELEASE_KP0, "0", "release", set()),
        ("\x1b[13;1:3u", "enter", "release", set()),
        ("\x1b[27;1:3u", "escape", "release", set()),
        ("\x1b[32;1:2u", "space", "repeat", set()),
        ("\x1b[3;1:3~", "delete", "release", set()),
        ("\x1b[57441;2:3u", "left_shift", "release", {"shift"}),
    ],
)
def test_parse_kitty_key_decodes(
    sequence: str, key: str, event_type: str, modifiers: set[str]
) -> None:
    decoded = parse_kitty_key(sequence)
    assert decoded is not None
    assert (decoded.key, decoded.event_type, decoded.modifiers) == (key, event_type, modifiers)


def test_parse_kitty_key_keeps_the_text() -> None:
    assert parse_kitty_key("\x1b[97;2;65u") == KittyKey(
        key="A", base="A", modifiers=frozenset({"shift"}), event_type="press", text="A"
    )


@pytest.mark.parametrize(
    "sequence",
    [
        BAD_EVENT_TYPE,
        "\x1b[1;1:0A",
        "\x1b[1;1:3:1A",
        "\x1b[2;1:3A",  # no such arrow code
        "\x1b[99999999u",
        "\x1b[55296u",  # a UTF-16 surrogate
        "\x1b[97;1;99999999u",
        "\x1b[u",
        "\x1b[\u0663u",  # an Arabic-Indic digit is not an ASCII parameter
        "\x1b[1;1:3",  # incomplete
        "\x1b[1;1:3X",
        "\x1b[1;1:3;3;A",
        "a",
        "",
    ],
)
def test_parse_kitty_key_rejects_malformed(sequence: str) -> None:
    assert parse_kitty_key(sequence) is None


_FINALS = st.sampled_from(["u", "~", "A", "B", "C", "D", "E", "F", "H", "P", "Q", "R", "S"])


@given(
    code=st.sampled_from(
        ["1", "2", "3", "5", "13", "27", "32", "65", "97", "122", "127", "233", "57399", "57441"]
    ),
    mods=st.one_of(st.none(), st.integers(1, 256).map(str)),
    text=st.one_of(st.none(), st.sampled_from([65, 97, 32, 233, 0x1F600]).map(str)),
    final=_FINALS,
)
def test_names_match_textuals_for_the_presses_it_reads(
    code: str, mods: str | None, text: str | None, final: str
) -> None:
    fields = [code] + ([mods or ""] if mods is not None or text is not None else [])
    fields += [text] if text is not None else []
    sequence = f"\x1b[{';'.join(fields)}{final}"
    try:
        textual_keys = XTermParser()._parse_extended_key(sequence)
    except ValueError:
        textual_keys = None
    decoded = parse_kitty_key(sequence)
    if final == "u" or f"{code}{final}" in FUNCTIONAL_KEYS:
        assert decoded is not None and textual_keys is not None
        assert decoded.key == textual_keys[0].key
    else:
        # Textual reads any code on any final as a character ("CSI 97 A" as "a"); kitty never
        # sends those, and we refuse them.
        assert decoded is None


@given(st.text(alphabet="\x1b[0123456789;:u~ABCDq", max_size=40))
def test_parse_kitty_key_never_raises(text: str) -> None:
    parse_kitty_key(text)
    parse_kitty_key("\x1b[" + text)


# --- the parser ---------------------------------------------------------------------------


def test_textual_alone_raises_on_event_types() -> None:
    """Why this module exists: the pinned Textual parser raises on a key release."""
    with pytest.raises(ValueError):
        list(XTermParser().feed(RELEASE_UP))


@pytest.mark.parametrize("chunk", [None, 1, 3])
def test_parser_turns_events_into_messages(chunk: int | None) -> None:
    data = "\x1b[A" + REPEAT_UP + REPEAT_UP + RELEASE_UP + RELEASE_A + RELEASE_KP0 + "x"
    assert described(feed(data, chunk=chunk)) == [
        ("key", "up", None),
        ("key", "up", True),
        ("key", "up", True),
        ("release", "up", None),
        ("release", "a", None),
        ("release", "0", None),
        ("key", "x", None),
    ]


def test_repeat_is_a_textual_key_with_a_flag() -> None:
    [repeat] = feed(REPEAT_UP)
    assert isinstance(repeat, events.Key) and isinstance(repeat, KittyKeyEvent)
    assert (repeat.key, repeat.repeat, repeat.handler_name) == ("up", True, "on_key")
    [press] = feed("\x1b[97;1:1;97u")
    assert isinstance(press, KittyKeyEvent)
    assert (press.key, press.character, press.repeat) == ("a", "a", False)
    [enter] = feed("\x1b[13;1:2u")
    assert enter.character == "\r"


def test_parser_drops_junk_and_keeps_going() -> None:
    junk = BAD_EVENT_TYPE + "\x1b[99999999u" + "\x1b[1;1:3;3;A" + "\x1b[97:;1:3:3u"
    assert described(feed(junk + "\x1b[B")) == [("key", "down", None)]


def test_plain_keys_are_untouched() -> None:
    data = "\x1b[A\x1b[1;5B\x1b[97;2;65uq\r"
    textual = [(type(m), m.key, m.character) for m in XTermParser().feed(data)]
    ours = [(type(m), m.key, m.character) for m in KittyParser().feed(data)]
    assert ours == textual


@settings(max_examples=300)
@given(
    data=st.text(alphabet="\x1b[0123456789;:uA~Bq", max_size=60),
    chunk=st.integers(1, 8),
)
def test_parser_never_raises(data: str, chunk: int) -> None:
    parser = KittyParser()
    for start in range(0, len(data), chunk):
        list(parser.feed(data[start : start + chunk]))
    # Still alive: a fresh escape after whatever came before is read.
    assert described(list(parser.feed("\x1b" + "\x1b[1;1:3A")))[-1] == ("release", "up", None)


# --- inside an app ------------------------------------------------------------------------


class ProbeApp(App[None]):
    """Records what reaches the screen and app, the way the play screen would see it."""

    BINDINGS = [("up", "moved", "Move")]

    def __init__(self) -> None:
        super().__init__(driver_class=KittyDriver)
        self.seen: list[tuple[str, str, bool | None]] = []
        self.moves = 0

    def action_moved(self) -> None:
        self.moves += 1

    def on_key(self, event: events.Key) -> None:
        self.seen.append(("key", event.key, key_repeat(event)))

    def on_key_release(self, event: KeyRelease) -> None:
        self.seen.append(("release", event.key, None))


def test_app_receives_repeats_and_releases() -> None:
    app = ProbeApp()
    assert app.driver_class is KittyDriver

    async def run() -> None:
        async with app.run_test() as pilot:
            # run_test swaps in Textual's headless driver; post what KittyDriver's parser yields.
            for message in feed("x" + REPEAT_UP + RELEASE_UP + BAD_EVENT_TYPE + RELEASE_A):
                app.post_message(message)
            await pilot.pause()
            assert app.is_running

    asyncio.run(run())
    assert app.seen == [
        ("key", "x", None),
        ("key", "up", True),
        ("release", "up", None),
        ("release", "a", None),
    ]
    # The repeat of "up" also ran the binding, as any key press does; the release did not.
    assert app.moves == 1


# --- the driver in a real pseudo-terminal -------------------------------------------------

_CHILD = """
import json, sys
from textual.app import App
from careful_tui.keys.kitty import KittyDriver, key_repeat

class Probe(App):
    def __init__(self):
        super().__init__(driver_class=KittyDriver)
        self.seen = []
    def on_key(self, event):
        self.seen.append(["key", event.key, key_repeat(event)])
        if event.key == "q":
            self.exit()
    def on_key_release(self, event):
        self.seen.append(["release", event.key])

app = Probe()
app.run()
with open(sys.argv[1], "w") as out:
    json.dump(app.seen, out)
"""


def _read_until(fd: int, needle: bytes, seen: bytearray, *, timeout: float) -> bool:
    end = time.monotonic() + timeout
    while needle not in seen and time.monotonic() < end:
        ready, _, _ = select.select([fd], [], [], 0.05)
        if ready:
            try:
                seen += os.read(fd, 65536)
            except OSError:
                break
    return needle in seen


@pytest.mark.skipif(sys.platform == "win32", reason="needs a POSIX pseudo-terminal")
def test_driver_in_a_pty_asks_for_events_and_survives_them(tmp_path: Path) -> None:
    import pty

    master, slave = pty.openpty()
    out_file = tmp_path / "seen.json"
    env = {**os.environ, "TERM": "xterm-256color", "PYTHONPATH": str(Path.cwd())}
    env.pop("TEXTUAL_DISABLE_KITTY_KEY", None)
    child = subprocess.Popen(
        [sys.executable, "-c", _CHILD, str(out_file)],
        stdin=slave,
        stdout=slave,
        stderr=slave,
        env=env,
        start_new_session=True,
    )
    os.close(slave)
    screen = bytearray()
    try:
        assert _read_until(master, b"\x1b[=2;2u", screen, timeout=20), bytes(screen[-500:])
        os.write(master, (REPEAT_UP + RELEASE_UP + BAD_EVENT_TYPE + RELEASE_KP0 + "q").encode())
        assert _read_until(master, b"\x1b[<u", screen, timeout=20), bytes(screen[-500:])
        assert child.wait(timeout=20) == 0
        _read_until(master, b"never sent", screen, timeout=0.2)  # whatever came after the pop
    finally:
        if child.poll() is None:
            child.kill()
            child.wait()
        os.close(master)
    screen_text = bytes(screen)
    assert b"Traceback" not in screen_text
    # Textual's own push, our flag on top of it, and our flag cleared before Textual's pop.
    assert screen_text.index(b"\x1b[>25u") < screen_text.index(b"\x1b[=2;2u")
    assert screen_text.index(b"\x1b[=2;3u") < screen_text.index(b"\x1b[<u")
    assert json.loads(out_file.read_text()) == [
        ["key", "up", True],
        ["release", "up"],
        ["release", "0"],
        ["key", "q", None],
    ]
