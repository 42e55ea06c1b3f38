"""Key releases and repeats from kitty's keyboard protocol, plugged into Textual 8.2.8.

Textual pushes the kitty protocol with flags 1|8|16 (disambiguate, all keys as escape codes,
associated text) and never asks for event types (flag 2), so it never sees a release. Worse, its
parser cannot read them: `CSI 1;1:3A` (release of up), `CSI 1;1:2A` (repeat) or `CSI 97;1:3u`
reach `int("1:3")` in `XTermParser._parse_extended_key`, the `ValueError` kills the input thread
and the app panics. This module adds:

- `parse_kitty_key`: a pure decoder of one key sequence into a `KittyKey`.
- `KittyParser`: Textual's parser, with the sequences it cannot read decoded here: a press or
  repeat becomes a `KittyKeyEvent` (an `events.Key`, so bindings and `on_key` see it as usual,
  with `.repeat` set), a release becomes a `KeyRelease` event (sent to the active screen,
  bubbling to the app), and anything malformed is dropped instead of raising.
- `KittyDriver`: the Linux/macOS driver using that parser and also asking for event types.
  Use it as `App(driver_class=KittyDriver)`. Terminals without the protocol ignore the request
  and keep sending plain presses and autorepeats. It subclasses Textual's POSIX driver, so this
  module does not import on Windows (there, leave `driver_class` unset). It also asks the
  terminal for its size, where Textual would believe COLUMNS and LINES.
- `PassiveKittyDriver`: the same, without asking for event types, for screens that have no use
  for releases (replay) but must not die when a terminal sends them anyway.

Private Textual APIs touched (hence the exact pin `textual==8.2.8`):
- `textual._xterm_parser.XTermParser._sequence_to_key_events`, overridden: the parse loop calls
  it for every candidate escape sequence; also `SPECIAL_KEY_TO_CHARACTER` from that module.
- `textual._keyboard_protocol.FUNCTIONAL_KEYS` and `MODIFIER_FUNCTIONAL_KEYS`, and
  `textual.keys._character_to_key`, to name keys exactly as Textual does.
- `LinuxDriver.run_input_thread`, copied with the parser swapped (the parser class is
  hard-wired there), with what it uses: `fileno`, `exit_event`, `_debug`,
  `textual._loop.loop_last`, `textual._parser.ParseError`; and `_writer_thread`, to skip the
  flag when Textual did not start its writer.
- `LinuxDriver._get_terminal_size`, overridden, and `_file`, the stream Textual draws on.

`App.run_test()` always uses Textual's headless driver, whatever `driver_class` says, so tests
feed byte strings to `KittyParser` directly and post the events it yields to a running app; a
pseudo-terminal test runs `KittyDriver` itself.
"""

from __future__ import annotations

import os
import re
import selectors
from codecs import getincrementaldecoder
from collections.abc import Iterable
from dataclasses import dataclass
from typing import ClassVar, Literal

from textual import constants, events
from textual._keyboard_protocol import FUNCTIONAL_KEYS, MODIFIER_FUNCTIONAL_KEYS
from textual._loop import loop_last
from textual._parser import ParseError
from textual._xterm_parser import SPECIAL_KEY_TO_CHARACTER, XTermParser
from textual.drivers.linux_driver import KITTY_REPORT_EVENT_TYPES, LinuxDriver
from textual.keys import Keys, _character_to_key

EventType = Literal["press", "repeat", "release"]

_EVENT_TYPES: dict[str, EventType] = {"": "press", "1": "press", "2": "repeat", "3": "release"}

# Modifier bits after subtracting 1 from the reported value (kitty spec, "Modifiers").
_MODIFIER_BITS = ("shift", "alt", "ctrl", "super", "hyper", "meta", "caps_lock", "num_lock")

# CSI key-code[:alternates] ; modifiers[:event-type] ; text-codepoints final
_re_key = re.compile(
    r"\x1b\[(?P<code>[\d:]*)(?:;(?P<mods>[\d:]*)(?:;(?P<text>[\d:]*))?)?(?P<final>[u~A-FHPQRS])",
    re.ASCII,
)

_MAX_CODEPOINT = 0x10FFFF


@dataclass(frozen=True)
class KittyKey:
    """One decoded key event.

    Attributes:
        key: the key as Textual names it, modifiers included ("up", "ctrl+up", "a", "A").
        base: the key without modifiers ("up", "a").
        modifiers: every modifier the terminal reported, caps_lock and num_lock included.
        event_type: "press", "repeat" or "release".
        text: the associated text, when the terminal reported it.
    """

    key: str
    base: str
    modifiers: frozenset[str]
    event_type: EventType
    text: str | None


def parse_kitty_key(sequence: str) -> KittyKey | None:
    """Decode one key sequence (`CSI ... u`, `CSI ... ~` or `CSI 1;... A`..`S`).

    Returns None for anything that is not a complete, well-formed key sequence: unknown event
    types, non-numeric fields, code points outside Unicode, unknown functional keys.
    """
    match = _re_key.fullmatch(sequence)
    if match is None:
        return None
    final = match["final"]
    code_parts = match["code"].split(":")
    mods_parts = (match["mods"] or "").split(":")
    text_field = match["text"]
    # Sub-fields after the first are alternate key codes, which we neither request nor need.
    if not all(part.isdecimal() or not part for part in code_parts) or len(mods_parts) > 2:
        return None
    code_str = code_parts[0] or ("1" if final not in "u~" else "")
    mods_str, event_str = (mods_parts + [""])[:2]
    if not code_str.isdecimal() or not (mods_str.isdecimal() or not mods_str):
        return None
    event_type = _EVENT_TYPES.get(event_str)
    text = _decode_text(text_field) if text_field else None
    if event_type is None or text == "":
        return None
    code = int(code_str)
    if (base := _base_name(code, final, text)) is None:
        return None
    bits = max(0, int(mods_str or "1") - 1)
    modifiers = frozenset(name for bit, name in enumerate(_MODIFIER_BITS) if bits & (1 << bit))
    return KittyKey(
        key=_textual_name(base, modifiers, text),
        base=base,
        modifiers=modifiers,
        event_type=event_type,
        text=text,
    )


def _decode_text(field: str) -> str:
    """Text code points joined by colons; "" when any is not a Unicode scalar value."""
    characters = []
    for part in field.split(":"):
        if not part.isdecimal():
            return ""
        codepoint = int(part)
        if codepoint > _MAX_CODEPOINT or 0xD800 <= codepoint <= 0xDFFF:
            return ""
        characters.append(chr(codepoint))
    return "".join(characters)


def _base_name(code: int, final: str, text: str | None) -> str | None:
    """The key name without modifiers, by Textual's rules (functional keys first)."""
    if functional := FUNCTIONAL_KEYS.get(f"{code}{final}"):
        return functional
    if final != "u" or code > _MAX_CODEPOINT or 0xD800 <= code <= 0xDFFF:
        return None
    return _character_to_key(text[0] if text else chr(code))


def _textual_name(base: str, modifiers: frozenset[str], text: str | None) -> str:
    """The full key name, with the modifiers Textual's `_parse_extended_key` would name.

    Textual drops shift and alt when the terminal reported text (the text already says "A"),
    never names caps_lock or num_lock, and names no modifier on a modifier key itself.
    """
    if base in MODIFIER_FUNCTIONAL_KEYS:
        return base
    named: list[str] = [
        name
        for name in ("alt", "ctrl", "super", "hyper", "meta")
        if name in modifiers and not (name == "alt" and text is not None)
    ]
    if "shift" in modifiers and (text is None or text[0].isspace()):
        named.append("shift")
    return "+".join([*sorted(named), base])


class KittyKeyEvent(events.Key):
    """A key press or autorepeat that the terminal labelled as such (kitty event types).

    It is an `events.Key`, so bindings and `on_key` handlers treat it like any key; `repeat`
    tells an explicit autorepeat (True) from an explicit press (False).
    """

    def __init__(self, key: str, character: str | None, *, repeat: bool) -> None:
        super().__init__(key, character)
        self.repeat = repeat


# Message.__init_subclass__ names the handler after the class (`on_kitty_key_event`); reset it
# so that every `on_key` handler and Textual's own `_on_key` binding dispatch receive it.
KittyKeyEvent.handler_name = events.Key.handler_name


@dataclass
class KeyRelease(events.InputEvent):
    """Sent when a key is released (only kitty-protocol terminals report it).

    The app forwards it to the active screen, where `on_key_release` handles it; it then
    bubbles to the app.
    """

    key: str
    """The key released, named as its press was ("up", "ctrl+up", "a")."""


def key_repeat(event: events.Key) -> bool | None:
    """Whether a key event is an autorepeat: True/False when the terminal said, else None."""
    return event.repeat if isinstance(event, KittyKeyEvent) else None


class KittyParser(XTermParser):
    """Textual's input parser, reading kitty event types instead of raising on them."""

    # Textual annotates this as yielding only keys, but its parse loop posts whatever it yields.
    def _sequence_to_key_events(  # type: ignore[override]
        self, sequence: str, alt: bool = False
    ) -> Iterable[events.Key | KeyRelease]:
        # The parse loop calls this for every prefix of an escape sequence and stops at the
        # first that yields anything, so only complete sequences may yield here. A colon in
        # the key code or modifiers field (alternate keys, event type) is what Textual cannot
        # read; a colon in the text field it reads, so it keeps those.
        match = _re_key.fullmatch(sequence)
        if match is not None and ":" in match["code"] + (match["mods"] or ""):
            yield self._kitty_event(sequence)
            return
        try:
            keys = list(super()._sequence_to_key_events(sequence, alt))
        except (ValueError, OverflowError):
            # Textual's own decoder raises on numbers it cannot turn into characters
            # (`CSI 99999999u`); the key is junk, so it is dropped like any ignored sequence.
            keys = [events.Key(Keys.Ignore, sequence)]
        yield from keys

    @staticmethod
    def _kitty_event(sequence: str) -> events.Key | KeyRelease:
        kitty = parse_kitty_key(sequence)
        if kitty is None:
            # The parse loop filters out Keys.Ignore after logging it.
            return events.Key(Keys.Ignore, sequence)
        if kitty.event_type == "release":
            return KeyRelease(kitty.key)
        character = kitty.text
        if character is None and not kitty.modifiers:
            character = SPECIAL_KEY_TO_CHARACTER.get(kitty.base)
        return KittyKeyEvent(kitty.key, character, repeat=kitty.event_type == "repeat")


class KittyDriver(LinuxDriver):
    """Textual's Linux/macOS driver, with key releases and repeats reported where possible.

    On start it sets the report-event-types flag on the kitty keyboard mode Textual pushed
    (`CSI = 2 ; 2 u`: set bits); on stop it clears the flag first, so releases of the keys that
    quit do not leak to the shell, and Textual's pop (`CSI < u`) restores the terminal.
    Honour `TEXTUAL_DISABLE_KITTY_KEY` like Textual; set `report_event_types = False` on a
    subclass to keep the parser's safety without asking for events.
    """

    report_event_types: ClassVar[bool] = True

    def _requests_event_types(self) -> bool:
        return self.report_event_types and not constants.DISABLE_KITTY_KEY

    def _get_terminal_size(self) -> tuple[int, int]:
        """The size of the terminal Textual draws on, asked of the terminal itself.

        Textual's driver asks `shutil.get_terminal_size`, which prefers COLUMNS and LINES when
        they are in the environment (a launcher that imported readline exports them, for one):
        the screen is then drawn at that size whatever the window's, and no resize is ever seen.
        """
        file = self._file
        try:
            width, height = os.get_terminal_size(file.fileno()) if file is not None else (0, 0)
        except (AttributeError, ValueError, OSError):
            width = height = 0
        return (width, height) if width and height else super()._get_terminal_size()

    def start_application_mode(self) -> None:
        super().start_application_mode()
        # Textual returns early, before creating its writer, when the terminal is not ours.
        if self._requests_event_types() and self._writer_thread is not None:
            self.write(f"\x1b[={KITTY_REPORT_EVENT_TYPES};2u")
            self.flush()

    def stop_application_mode(self) -> None:
        if self._requests_event_types() and self._writer_thread is not None:
            self.write(f"\x1b[={KITTY_REPORT_EVENT_TYPES};3u")
            self.flush()
        super().stop_application_mode()

    def run_input_thread(self) -> None:
        """Textual 8.2.8's `LinuxDriver.run_input_thread`, with `KittyParser` as the parser."""
        selector = selectors.SelectSelector()
        selector.register(self.fileno, selectors.EVENT_READ)

        fileno = self.fileno
        EVENT_READ = selectors.EVENT_READ

        parser = KittyParser(self._debug)
        feed = parser.feed
        tick = parser.tick

        decode = getincrementaldecoder("utf-8")().decode
        read = os.read

        def process_selector_events(
            selector_events: list[tuple[selectors.SelectorKey, int]],
            final: bool = False,
        ) -> None:
            for last, (_selector_key, mask) in loop_last(selector_events):
                if mask & EVENT_READ:
                    unicode_data = decode(read(fileno, 1024 * 4), final=final and last)
                    if not unicode_data:
                        # This can occur if the stdin is piped.
                        break
                    for event in feed(unicode_data):
                        self.process_message(event)
            for event in tick():
                self.process_message(event)

        try:
            while not self.exit_event.is_set():
                process_selector_events(selector.select(0.1))
            selector.unregister(self.fileno)
            process_selector_events(selector.select(0.1), final=True)
        finally:
            selector.close()
            try:
                for _event in feed(""):
                    pass
            except (EOFError, ParseError):
                pass


class PassiveKittyDriver(KittyDriver):
    """`KittyDriver` that reads kitty release and repeat sequences without asking for them.

    A terminal may send them unasked (for one, after a `careful play` killed before it could
    withdraw its request), and Textual's own driver dies on the first. Here a repeat is a key
    like any other and a release is an event nobody needs to handle.
    """

    report_event_types = False
