"""uvicorn's HTTP/1.1 protocol with what `careful serve` promises of every connection.

uvicorn drops neither a connection that never finishes sending its request's headers (400 such
connections stayed open, each a file descriptor) nor answers its own 400s (a request it cannot
parse) with the server's security headers. This protocol closes a connection that has not sent a
whole request head within `HEADER_TIMEOUT_S` of opening, or of its last answer, and answers
uvicorn's 400 in the server's one error shape with `SECURITY_HEADERS`. The body has its own
timeout in the app (`server.BODY_TIMEOUT_S`).
"""

from __future__ import annotations

import asyncio
import json

import h11
from uvicorn.protocols.http.h11_impl import H11Protocol

from careful_tui.web.server import SECURITY_HEADERS

HEADER_TIMEOUT_S = 10.0


class GuardedH11Protocol(H11Protocol):
    """`H11Protocol` with a timeout on each request's head and the security headers on its 400s."""

    header_timeout_s = HEADER_TIMEOUT_S

    def connection_made(self, transport: asyncio.Transport) -> None:  # type: ignore[override]
        super().connection_made(transport)
        self._arm_header_timer()

    def on_response_complete(self) -> None:
        super().on_response_complete()
        self._arm_header_timer()

    def _arm_header_timer(self) -> None:
        """Close the connection if no new request head has come in `header_timeout_s`."""
        waiting_after = self.cycle

        def drop() -> None:
            if self.cycle is waiting_after and not self.transport.is_closing():
                self.transport.close()

        self.loop.call_later(self.header_timeout_s, drop)

    def send_400_response(self, msg: str) -> None:
        body = json.dumps({"error": "The request could not be read."}).encode()
        headers = [(b"content-type", b"application/json"), (b"connection", b"close"),
                   *((name.encode(), value.encode()) for name, value in SECURITY_HEADERS.items())]
        for event in (h11.Response(status_code=400, headers=headers, reason=b"Bad Request"), h11.Data(data=body),
                      h11.EndOfMessage()):
            try:
                self.transport.write(self.conn.send(event))
            except h11.LocalProtocolError:
                break  # h11 cannot answer this connection any more: it is closed below
        self.transport.close()
