"""`careful serve`'s web server: the study's page, and the few requests the page makes.

Starlette (a small, well-kept ASGI toolkit) routes the requests and uvicorn serves them; the page
is one HTML file with its script and stylesheet, shipped in the package (``static/``), with no
build step and nothing from elsewhere. The app has Starlette's own shape: the endpoints are
module-level functions in the module-level `routes`, and what they share (the study, its links,
the seats) is one `Served` in the lifespan state (``request.state.served``); `make_app` only
builds it. What an endpoint does with a participant's files runs in a thread (`arrive`, `play_key`).

=====================  ================================================================
request                answer
=====================  ================================================================
GET /p/<token>         the page, for a token in ``<out>/links.csv``; any other: 404
GET /?PROLIFIC_PID=..  when Prolific links are on (``--prolific``, or no links): the page,
                       for a Prolific id that passes the study's id rules (with STUDY_ID
                       and SESSION_ID), else a page that says why: 400; when off: 404
POST /api/start        the page claims its participant: its page id and the first view;
                       409 while another page of theirs plays, 429 beyond the address's
                       budget of new pages, 503 when every seat is taken
POST /api/key          a key (press, release, cancel, space, quit) or a reach (reach_press
                       with its aim, reach_release; reach_own with the pointer's endpoint
                       and duration): the new view;
                       410 for a page that no longer plays, 429 beyond the key budget
POST /api/alive        the page's heartbeat: 204, or 410
POST /api/leave        the page closes (sent as a beacon): 204
=====================  ================================================================

Every request body is JSON of at most `MAX_BODY` bytes (413 beyond), sent within `BODY_TIMEOUT_S`
(408 beyond); every refusal is the one JSON shape ``{"error": sentence}``, worded for the
participant (the console gets the reasons: who holds a lock, a full disk). Nothing the page sends
names a file or chooses an outcome: a participant id comes from the links file or a checked
Prolific id, and the session draws every start cell and slip. Every answer carries a
Content-Security-Policy that lets the page load only this server's script and stylesheet; every
text from a study or world file travels as a JSON string and is drawn with ``textContent``.
"""

from __future__ import annotations

import contextlib
import html
import json
import math
from collections.abc import AsyncIterator, Awaitable, Callable
from dataclasses import dataclass
from importlib import resources
from typing import Any
from urllib.parse import quote

import anyio
from starlette.applications import Starlette
from starlette.concurrency import run_in_threadpool
from starlette.exceptions import HTTPException
from starlette.middleware import Middleware
from starlette.requests import ClientDisconnect, Request
from starlette.responses import HTMLResponse, JSONResponse, Response
from starlette.routing import Mount, Route
from starlette.staticfiles import StaticFiles

from careful_tui.web.links import prolific_ids
from careful_tui.web.seat_files import SharedSeats
from careful_tui.web.seats import Seat, Seats
from careful_tui.web.session_adapter import WebSession
from irl_core.errors import BodyTooLarge, BodyTooSlow, KeyRefused, ParticipantBusy, SeatRefused, SeatUnavailable, StudyError
from irl_core.recordings.lines import ProlificTag
from irl_core.studies.participant_lock import participant_lock
from irl_core.studies.study import LoadedStudy
from irl_core.support.safe_text import printable

MAX_BODY = 2048
BODY_TIMEOUT_S = 10.0
COMPLETION_ADDRESS = "https://app.prolific.com/submissions/complete?cc="
SWEEP_S = 5.0
SECURITY_HEADERS = {
    "content-security-policy": "default-src 'none'; script-src 'self'; style-src 'self'; img-src 'self'; "
                               "connect-src 'self'; base-uri 'none'; form-action 'none'; frame-ancestors 'none'",
    "x-content-type-options": "nosniff",
    "referrer-policy": "no-referrer",
    "cache-control": "no-store",
    "x-frame-options": "DENY",
}
KEY_TYPES = ("press", "release", "cancel", "space", "quit", "reach_press", "reach_release", "reach_own")


class SecurityHeaders:
    """ASGI middleware: `SECURITY_HEADERS` on every response."""

    def __init__(self, app, *, worker: int | None = None) -> None:
        self.app = app
        # With several workers, which one answered (the load bench and the tests count them).
        more = {} if worker is None else {"x-careful-worker": str(worker)}
        self.headers = [(k.encode(), v.encode()) for k, v in (SECURITY_HEADERS | more).items()]

    async def __call__(self, scope, receive, send) -> None:
        if scope["type"] != "http":
            await self.app(scope, receive, send)
            return

        async def send_with_headers(message) -> None:
            if message["type"] == "http.response.start":
                message.setdefault("headers", [])
                message["headers"] = [*message["headers"], *self.headers]
            await send(message)

        await self.app(scope, receive, send_with_headers)


def completion_url(code: str) -> str:
    return COMPLETION_ADDRESS + quote(code, safe="")


def notice_page(title: str, text: str, *, status: int) -> HTMLResponse:
    """A page that says one thing (an unknown link, an id that cannot be used), escaped as text."""
    body = (f'<!doctype html><html lang="en"><head><meta charset="utf-8"><meta name="viewport" '
            f'content="width=device-width, initial-scale=1"><title>{html.escape(title)}</title>'
            f'<link rel="stylesheet" href="/static/page.css"></head><body><main class="notice-page">'
            f'<h1>{html.escape(title)}</h1><p>{html.escape(text)}</p></main></body></html>')
    return HTMLResponse(body, status_code=status)


async def read_json(request: Request) -> dict[str, Any]:
    """The request's JSON object, read no further than `MAX_BODY` bytes.

    Raises:
        BodyTooLarge: the body is longer.
        ValueError: it is not a JSON object.
    """
    declared = request.headers.get("content-length")
    if declared is not None and (not declared.isdigit() or int(declared) > MAX_BODY):
        raise BodyTooLarge
    body = bytearray()
    try:
        with anyio.fail_after(BODY_TIMEOUT_S):
            async for chunk in request.stream():
                body += chunk
                if len(body) > MAX_BODY:
                    raise BodyTooLarge
    except TimeoutError:
        raise BodyTooSlow from None
    try:
        data = json.loads(body.decode("utf-8"), parse_constant=lambda name: math.nan)
    except RecursionError:
        raise ValueError("nested too deeply") from None
    if not isinstance(data, dict):
        raise ValueError("not a JSON object")
    return data


def refuse(status: int, why: str) -> JSONResponse:
    return JSONResponse({"error": why}, status_code=status)


async def http_refusal(request: Request, exc: Exception) -> Response:
    """Starlette's own refusals (404, 405) in the one error shape."""
    status = exc.status_code if isinstance(exc, HTTPException) else 500
    return refuse(status, {404: "There is nothing here.", 405: "This address does not take that request."}
                  .get(status, "The request cannot be served."))


async def server_error(request: Request, exc: Exception) -> Response:
    """An unexpected error: the one error shape, no traceback (uvicorn's log has it)."""
    return refuse(500, "Something went wrong on the server. Please reload the page; if this comes back, "
                       "write to the experimenter.")


def json_endpoint(handle: Callable[[Request, dict[str, Any]], Awaitable[Response]]):
    """An endpoint that takes `read_json`'s object: 413 for a body over the limit, 408 for one too slow, 400 for
    one not JSON or cut off by the client's leaving."""

    async def endpoint(request: Request) -> Response:
        try:
            data = await read_json(request)
        except BodyTooLarge:
            return refuse(413, "The request is too large.")
        except BodyTooSlow:
            return refuse(408, "The request took too long to arrive. Please reload the page.")
        except ClientDisconnect:  # the client left mid-body: nobody reads the answer, and the console needs no traceback
            return refuse(400, "The request ended before its body arrived.")
        except ValueError:
            return refuse(400, "The request is not JSON.")
        return await handle(request, data)

    return endpoint


@dataclass
class Served:
    """What every request shares, in the app's lifespan state (``request.state.served``).

    Attributes:
        study: the study served.
        links: token -> participant id, from ``links.csv``.
        seats: the pages playing now (`careful_tui.web.seats`; with several workers, in files:
            `careful_tui.web.seat_files`).
        say: a line for the experimenter's console.
        completion_code: Prolific's, for the end screen of a Prolific participant (None: no redirect).
        seed: every block's seed (a test's); None draws one per block.
        prolific: whether Prolific links are taken.
        page_html: the one page.
    """

    study: LoadedStudy
    links: dict[str, str]
    seats: Seats | SharedSeats
    say: Callable[[str], None]
    completion_code: str | None
    seed: int | None
    prolific: bool
    page_html: str


UNKNOWN_LINK = ("This link is not valid", "Check that you copied the whole link you were given; if it still "
                "does not open, write to the experimenter.")


def served_by(request: Request) -> Served:
    return request.state.served


# ---------------------------------------------------------------------- the endpoints


def page(request: Request) -> Response:
    """GET /p/<token>: the page, for a token in the links file."""
    served = served_by(request)
    if request.path_params["token"] not in served.links:
        return notice_page(*UNKNOWN_LINK, status=404)
    return HTMLResponse(served.page_html)


def home(request: Request) -> Response:
    """GET /: the page for a Prolific link (when they are on), else a page that says to use one's link."""
    served, query = served_by(request), request.query_params
    if "PROLIFIC_PID" not in query or not served.prolific:
        return notice_page("This study opens from your link", "Open the link you were given to take part.", status=404)
    try:
        prolific_ids(query.get("PROLIFIC_PID", ""), query.get("STUDY_ID", ""), query.get("SESSION_ID", ""))
    except StudyError as exc:
        return notice_page("This link cannot be used", f"{exc}. Open the study again from Prolific; if this "
                           "page comes back, write to the experimenter.", status=400)
    return HTMLResponse(served.page_html)


def favicon(request: Request) -> Response:
    return Response(status_code=204)


@json_endpoint
async def start(request: Request, data: dict[str, Any]) -> Response:
    """POST /api/start: the page claims its participant."""
    user_agent = printable(request.headers.get("user-agent", ""), limit=400)
    address = request.client.host if request.client is not None else ""
    return await run_in_threadpool(arrive, served_by(request), data, user_agent, address)


@json_endpoint
async def key(request: Request, data: dict[str, Any]) -> Response:
    """POST /api/key: a key of a page that plays."""
    return await run_in_threadpool(play_key, served_by(request), data)


@json_endpoint
async def alive(request: Request, data: dict[str, Any]) -> Response:
    """POST /api/alive: the page's heartbeat."""
    seated = await run_in_threadpool(served_by(request).seats.keep_alive, data.get("page"))
    return Response(status_code=204 if seated else 410)


@json_endpoint
async def leave(request: Request, data: dict[str, Any]) -> Response:
    """POST /api/leave: the page closes."""
    await run_in_threadpool(served_by(request).seats.leave, data.get("page"), "left (closed the page)")
    return Response(status_code=204)


routes = [
    Route("/", home),
    Route("/favicon.ico", favicon),
    Route("/p/{token}", page),
    Route("/api/start", start, methods=["POST"]),
    Route("/api/key", key, methods=["POST"]),
    Route("/api/alive", alive, methods=["POST"]),
    Route("/api/leave", leave, methods=["POST"]),
    Mount("/static", StaticFiles(packages=[("careful_tui.web", "static")]), name="static"),
]


# ---------------------------------------------------------------------- what the endpoints do (in a thread)


def arrive(served: Served, data: dict[str, Any], user_agent: str, address: str) -> Response:
    """A page claims its participant, by a link's token or a Prolific id: its page id and first view."""
    prolific: ProlificTag | None = None
    if "token" in data:
        participant = served.links.get(data["token"]) if isinstance(data["token"], str) else None
        if participant is None:
            return refuse(404, "This link is not valid.")
        came = "link"
    elif not served.prolific:
        return refuse(404, "This link is not valid.")
    else:
        ids = data.get("prolific")
        if not isinstance(ids, dict) or not all(isinstance(ids.get(k), str) for k in ("pid", "study_id", "session_id")):
            return refuse(400, "The page was opened without a participant link.")
        try:
            participant, study_id, session_id = prolific_ids(ids["pid"], ids["study_id"], ids["session_id"])
        except StudyError as exc:
            return refuse(400, f"{exc}.")
        prolific = ProlificTag(study_id=study_id, session_id=session_id)
        came = "Prolific"
    code = served.completion_code
    url = completion_url(code) if code is not None and prolific is not None else None

    def make_session() -> WebSession:
        return WebSession(served.study, participant, user_agent=user_agent, prolific=prolific, completion_url=url,
                          say=served.say, seed=served.seed)

    try:
        seat = served.seats.claim(participant, make_session, address=address, hold=lambda: participant_lock(
            served.study, participant, holder="careful serve (a browser page)"))
    except SeatRefused as exc:
        return refuse(exc.status, exc.why)
    except (StudyError, OSError) as exc:
        return lock_refusal(served, participant, exc)
    if seat is None:
        return refuse(409, "This study is already open for you in another tab, window or device. Go on "
                           "there; or close it, wait a few seconds, and reload this page.")
    done, total = seat.session.protocol.progress
    served.say(f"{participant}: opened the page from a {came} ({done} of {total} episodes done)")
    with seat.lock:
        return JSONResponse({"page": seat.page, "view": seat.session.view()})


def lock_refusal(served: Served, participant: str, exc: Exception) -> JSONResponse:
    """409 when another session holds the participant, else 503 (a full disk, the out folder
    gone: the experimenter's to mend); the participant is told what to do, the console why."""
    if isinstance(exc, ParticipantBusy):
        served.say(f"{participant}: refused a page: open in another session ({printable(exc.holder, limit=200)})")
        return refuse(409, "This study is already open for you elsewhere. Go on there, or finish it first.")
    served.say(f"{participant}: cannot open a session: {printable(str(exc), limit=300)}")
    return refuse(503, "The study cannot save anything just now. Please try again in a few minutes; "
                       "if this comes back, write to the experimenter.")


def play_key(served: Served, data: dict[str, Any]) -> Response:
    """A key event of a page: the new view, or a refusal; a page that has left frees its seat."""
    kind = data.get("type")
    if not isinstance(kind, str) or kind not in KEY_TYPES:
        return refuse(400, "Unknown key event.")
    try:
        with served.seats.playing(data.get("page")) as seat:
            if seat is None:
                return refuse(410, "This page no longer plays: reload it to go on.")
            return play_locked(served, seat, kind, data)
    except SeatUnavailable as exc:  # seats in files: the participant's lock or seat, for this one request
        return lock_refusal(served, exc.participant, exc.cause)


def play_locked(served: Served, seat: Seat, kind: str, data: dict[str, Any]) -> Response:
    """The key `kind` on `seat`'s session (under `seat.lock`): the new view, or a refusal."""
    session = seat.session
    if session.left:
        return refuse(410, "This page has left the study.")
    if not seat.budget.spend():
        session.cancel()
        why = "Too many keys at once: nothing was played. Slow down."
        session.tell(why)
        return refuse(429, why)
    if kind not in ("cancel", "quit"):
        try:
            seat.take_lock()  # a seat holds no file until its first key
        except (StudyError, OSError) as exc:
            session.left = True  # nothing of this page was played or written: it only stops
            return lock_refusal(served, seat.participant, exc)
    try:
        if kind == "press":
            session.press(data.get("key"), data.get("t"))
        elif kind == "release":
            session.release(data.get("key"), data.get("t"))
        elif kind == "reach_press":
            session.reach_press(data.get("aim"), data.get("t"))
        elif kind == "reach_release":
            session.reach_release(data.get("t"))
        elif kind == "reach_own":
            session.reach_own(data.get("endpoint"), data.get("duration_ms"))
        elif kind == "cancel":
            session.cancel()
        elif kind == "space":
            session.space()
        else:
            session.leave()
    except KeyRefused as exc:
        return refuse(400, str(exc))
    except (OSError, ValueError) as exc:
        served.say(f"{seat.participant}: cannot write the recording ({printable(str(exc), limit=200)}); "
                   "the participant was stopped")
        session.leave("stopped: the recording cannot be written")
        return refuse(503, "The study cannot save your moves just now; nothing more can be played. "
                           "Please write to the experimenter.")
    return JSONResponse({"view": session.view()})


# ---------------------------------------------------------------------- the app


@contextlib.asynccontextmanager
async def lifespan(app: Starlette) -> AsyncIterator[dict[str, Served]]:
    """The app's life: `Served` in every request's state; silent pages swept; every seat released at the end."""
    served: Served = app.state.served
    async with anyio.create_task_group() as tasks:
        async def sweep() -> None:
            while True:
                await anyio.sleep(SWEEP_S)
                await run_in_threadpool(served.seats.release_silent)

        tasks.start_soon(sweep)
        try:
            yield {"served": served}
        finally:
            tasks.cancel_scope.cancel()
            served.seats.release_all("left (the server stopped)")


def make_app(study: LoadedStudy, *, links: dict[str, str], completion_code: str | None = None,
             say: Callable[[str], None] = print, seed: int | None = None, seats: Seats | SharedSeats | None = None,
             prolific: bool | None = None, worker: int | None = None) -> Starlette:
    """The server's ASGI app for `study`, its participants from `links` (token -> id) and, when
    `prolific` (default: only when there are no links), Prolific links; `worker` numbers it among
    several (`careful_tui.web.workers`), whose seats are `SharedSeats`."""
    page_html = resources.files("careful_tui.web").joinpath("static/page.html").read_text(encoding="utf-8")
    app = Starlette(routes=routes, middleware=[Middleware(SecurityHeaders, worker=worker)], lifespan=lifespan,
                    exception_handlers={HTTPException: http_refusal, Exception: server_error})
    app.router.redirect_slashes = False  # its redirect would go to whatever host the Host header names
    app.state.served = Served(study, links, Seats() if seats is None else seats, say, completion_code, seed,
                              not links if prolific is None else prolific, page_html)
    return app
