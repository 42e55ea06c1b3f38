"""Whether the terminal reports key releases, asked before a time world is played (docs/timing.md).

A time world's care is how long a key is held, from key-down to key-up. A terminal speaking kitty's
keyboard protocol reports the key-up; others report only presses and autorepeats, from which a hold
could only be guessed. `reports_key_releases` asks the terminal for its kitty keyboard flags (``CSI ? u``)
and then for its primary device attributes (``CSI c``), which every terminal answers: a flags reply
before the attributes means the protocol is spoken (the way kitty's documentation says to detect it).
``CAREFUL_KEY_RELEASES=yes`` or ``no`` overrides the question, for a terminal whose answer is wrong.
"""

from __future__ import annotations

import os
import re
import select
import termios
import time
import tty

_FLAGS = re.compile(rb"\x1b\[\?\d*u")
_ATTRIBUTES = re.compile(rb"\x1b\[\?[\d;]*c")
OVERRIDE = "CAREFUL_KEY_RELEASES"


def reports_key_releases(*, timeout_s: float = 0.5) -> bool:
    """True when the controlling terminal speaks kitty's keyboard protocol (or the override says yes)."""
    said = os.environ.get(OVERRIDE, "").strip().lower()
    if said in ("yes", "no"):
        return said == "yes"
    try:
        fd = os.open("/dev/tty", os.O_RDWR | os.O_NOCTTY)
    except OSError:
        return False
    try:
        saved = termios.tcgetattr(fd)
    except termios.error:
        os.close(fd)
        return False
    try:
        tty.setraw(fd)
        os.write(fd, b"\x1b[?u\x1b[c")
        answer = b""
        deadline = time.monotonic() + timeout_s
        while (left := deadline - time.monotonic()) > 0:
            ready, _, _ = select.select([fd], [], [], left)
            if not ready:
                break
            answer += os.read(fd, 1024)
            if _FLAGS.search(answer):
                return True
            if _ATTRIBUTES.search(answer):
                return False
        return False
    finally:
        termios.tcsetattr(fd, termios.TCSADRAIN, saved)
        os.close(fd)
