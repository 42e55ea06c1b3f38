"""`careful serve`: check the study, write any new links, and serve the study until Ctrl+C."""

from __future__ import annotations

import argparse
import re
import signal
import socket

from irl_core.errors import LinksError, StudyError, UsageError
from irl_core.recordings.writer import check_writable
from irl_core.studies.study import LoadedStudy, load_study
from irl_core.support.safe_files import write_problem
from irl_core.support.safe_text import printable

_COMPLETION_CODE = re.compile(r"[A-Za-z0-9_-]{1,40}")


def say(line: str) -> None:
    """A line for the experimenter, at once (the server's console is often a log)."""
    print(printable(line), flush=True)


def run_serve(args: argparse.Namespace) -> int:
    """`careful serve STUDY.toml [--host H] [--port N] [--links N] [--completion-code CODE] [--workers N]`."""
    from careful_tui.web.links import MOST_LINKS, add_links, read_links
    from careful_tui.web.server import make_app
    from careful_tui.web.workers import most_workers

    if not args.host.strip():
        raise UsageError("--host needs an address: 127.0.0.1 (this machine only) or 0.0.0.0 (every interface)")
    if args.workers > most_workers():
        raise UsageError(f"--workers {args.workers} is more than this machine can use (at most {most_workers()}: "
                         "4 per core)")
    if args.links > MOST_LINKS:
        raise UsageError(f"--links {args.links:,} is more than one start may add ({MOST_LINKS:,}); add them in parts")

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
    prolific = args.prolific or not links
    if args.workers > 1:
        return serve_workers(args, study, sock, new=new, links=links, prolific=prolific)
    server = make_server(make_app(study, links=links, completion_code=args.completion_code, say=say, prolific=prolific))
    # From the first line on, Ctrl+C or SIGTERM is a stop (before uvicorn runs, and while it runs).
    stopping = {sig: signal.signal(sig, lambda *_: setattr(server, "should_exit", True))
                for sig in (signal.SIGINT, signal.SIGTERM)}
    try:
        announce(args, study, sock, new=new, links=links, prolific=prolific)
        server.run(sockets=[sock])
    finally:
        for sig, handler in stopping.items():
            signal.signal(sig, handler)
    say("careful serve: stopped; every recording is closed")
    return 0


def serve_workers(args: argparse.Namespace, study: LoadedStudy, sock: socket.socket, *, new: list[tuple[str, str]],
                  links: dict[str, str], prolific: bool) -> int:
    """`--workers N` > 1: the worker processes on `sock` (`careful_tui.web.workers`) until Ctrl+C."""
    from careful_tui.web.workers import WorkerSettings, new_key, supervise

    settings = WorkerSettings(args.study.resolve(), args.completion_code, prolific, new_key())
    announce(args, study, sock, new=new, links=links, prolific=prolific)
    say(f"workers: {args.workers} processes; the pages' seats in {study.out}/.<participant>.seat")
    code = supervise(settings, sock, workers=args.workers, say=say, make_server=make_server)
    sock.close()
    say("careful serve: stopped; every recording is closed" if code == 0 else "careful serve: stopped")
    return code


def announce(args: argparse.Namespace, study: LoadedStudy, sock: socket.socket, *, new: list[tuple[str, str]],
             links: dict[str, str], prolific: bool) -> None:
    """The experimenter's first lines: where the study is served, the links, Prolific, the recordings."""
    from careful_tui.web.links import LINKS_FILE, link_path

    base = f"http://{args.host if ':' not in args.host else f'[{args.host}]'}:{sock.getsockname()[1]}"
    say(f"careful serve: study {study.study.name!r} at {base}/ (Ctrl+C stops)")
    if new:
        say(f"links: {len(new)} new appended to {study.out / LINKS_FILE}, {len(links)} in all")
    elif links:
        say(f"links: {len(links)} in {study.out / LINKS_FILE}")
    for participant, token in new[:3]:
        say(f"  {participant}: {base}{link_path(token)}")
    say(prolific_line(base, args.completion_code) if prolific else
        "Prolific: off (links only; --prolific also takes Prolific links, as participants of their own)")
    say(f"recordings: {study.out}/<participant>/")


def prolific_line(base: str, code: str | None) -> str:
    """The Prolific study's address for the experimenter to paste, with Prolific's placeholders."""
    return (f"Prolific: {base}/?PROLIFIC_PID={{{{%PROLIFIC_PID%}}}}&STUDY_ID={{{{%STUDY_ID%}}}}&SESSION_ID={{{{%SESSION_ID%}}}}"
            + (f" (completion code {code})" if code else " (no --completion-code: no redirect)"))


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


def make_server(app, *, header_timeout_s: float | None = None):
    """The uvicorn server for `app`: Ctrl+C (or SIGTERM) stops it taking requests, then the app's
    shutdown closes every participant's file. Run it with ``.run(sockets=[bind(...)])``; it
    returns once stopped.

    Connections are bounded (`connection_limit`: 503 beyond), and each request head must arrive
    within `header_timeout_s` (`careful_tui.web.guarded_http`)."""
    import uvicorn

    from careful_tui.web.guarded_http import GuardedH11Protocol

    class Protocol(GuardedH11Protocol):
        pass

    if header_timeout_s is not None:
        Protocol.header_timeout_s = header_timeout_s

    class Server(uvicorn.Server):
        def handle_exit(self, sig: int, frame: object) -> None:
            # One stop, however many signals: uvicorn forces a second Ctrl+C through the app's
            # shutdown (tracebacks, files left open) and raises SIGTERM again once stopped, which
            # ended the process before its "stopped" line. The shutdown is bounded anyway.
            self.should_exit = True

    config = uvicorn.Config(app, log_level="warning", access_log=False, lifespan="on", timeout_graceful_shutdown=3,
                            server_header=False, http=Protocol, limit_concurrency=connection_limit())
    return Server(config)


def connection_limit() -> int:
    """Connections served at once: half of what the open-file limit leaves (seats take the rest)."""
    import resource

    from careful_tui.web.seats import FILES_KEPT, MOST_SEATS

    soft, _ = resource.getrlimit(resource.RLIMIT_NOFILE)
    room = 4 * MOST_SEATS if soft == resource.RLIM_INFINITY else (soft - FILES_KEPT) // 2
    return max(16, min(4 * MOST_SEATS, room))
