"""`careful serve`: check the study, write any new links, and serve the study until Ctrl+C."""

from __future__ import annotations

import argparse
import re
import socket

from careful_tui.errors import UsageError
from irl_core.recordings.writer import check_writable
from irl_core.studies.study import StudyError, load_study
from irl_core.support.safe_files import write_problem
from irl_core.support.safe_text import printable

_COMPLETION_CODE = re.compile(r"[A-Za-z0-9_-]{1,40}")


def say(line: str) -> None:
    """A line for the experimenter, at once (the server's console is often a log)."""
    print(printable(line), flush=True)


def run_serve(args: argparse.Namespace) -> int:
    """`careful serve STUDY.toml [--host H] [--port N] [--links N] [--completion-code CODE]`."""
    from careful_tui.web.links import LINKS_FILE, LinksError, add_links, link_path, read_links
    from careful_tui.web.server import make_app

    try:
        study = load_study(args.study)
    except StudyError as exc:
        raise UsageError(str(exc)) from None
    if args.completion_code is not None and not _COMPLETION_CODE.fullmatch(args.completion_code):
        raise UsageError("--completion-code takes Prolific's code as it is: 1 to 40 letters, digits, _ and -")
    if study.out.exists() and not study.out.is_dir():
        raise UsageError(f"{printable(str(study.out))} is a file, not the study's out folder; move it away")
    try:
        check_writable(study.out)
    except OSError as exc:
        raise UsageError(f"cannot write recordings to {printable(str(study.out))} ({write_problem(exc)}); "
                         "check the study's out folder") from None
    sock = bind(args.host, args.port)
    try:
        new = add_links(study, args.links) if args.links else []
        links = read_links(study)
    except LinksError as exc:
        sock.close()
        raise UsageError(str(exc)) from None
    base = f"http://{args.host if ':' not in args.host else f'[{args.host}]'}:{sock.getsockname()[1]}"
    say(f"careful serve: study {study.study.name!r} at {base}/ (Ctrl+C stops)")
    if new:
        say(f"links: {len(new)} new appended to {study.out / LINKS_FILE}, {len(links)} in all")
    elif links:
        say(f"links: {len(links)} in {study.out / LINKS_FILE}")
    for participant, token in new[:3]:
        say(f"  {participant}: {base}{link_path(token)}")
    say(f"Prolific: {base}/?PROLIFIC_PID={{{{%PROLIFIC_PID%}}}}&STUDY_ID={{{{%STUDY_ID%}}}}&SESSION_ID={{{{%SESSION_ID%}}}}"
        + (f" (completion code {args.completion_code})" if args.completion_code else " (no --completion-code: no redirect)"))
    say(f"recordings: {study.out}/<participant>/")
    app = make_app(study, links=links, completion_code=args.completion_code, say=say)
    try:
        make_server(app).run(sockets=[sock])
    except KeyboardInterrupt:
        pass  # uvicorn raises Ctrl+C again once it has shut down, every participant's file closed
    say("careful serve: stopped; every recording is closed")
    return 0


def bind(host: str, port: int) -> socket.socket:
    """A listening socket on `host`:`port` (0: any free port), or one line saying what to do."""
    family = socket.AF_INET6 if ":" in host else socket.AF_INET
    # IPPROTO_TCP named, so asyncio sets TCP_NODELAY on each connection: with protocol 0 it does not,
    # and a response's body then waits for the browser's delayed ACK of its headers (40 ms a request).
    sock = socket.socket(family, socket.SOCK_STREAM, socket.IPPROTO_TCP)
    sock.setsockopt(socket.SOL_SOCKET, socket.SO_REUSEADDR, 1)
    try:
        sock.bind((host, port))
        sock.listen(128)
    except OSError as exc:
        sock.close()
        raise UsageError(f"cannot listen on {printable(host)}:{port} ({exc.strerror or exc}); "
                         "choose another --port or --host") from None
    sock.set_inheritable(True)
    return sock


def make_server(app):
    """The uvicorn server for `app`: Ctrl+C (or SIGTERM) stops it taking requests, then the app's
    shutdown closes every participant's file. Run it with ``.run(sockets=[bind(...)])``."""
    import uvicorn

    config = uvicorn.Config(app, log_level="warning", access_log=False, lifespan="on", timeout_graceful_shutdown=3,
                            server_header=False)
    return uvicorn.Server(config)
