"""`careful serve`: check the study, write any new links, and serve the study until Ctrl+C."""

from __future__ import annotations

import argparse
import ipaddress
import re
import signal
import socket
from collections.abc import Callable
from typing import TYPE_CHECKING

from irl_core.errors import LinksError, StudyError, UsageError
from irl_core.recordings.writer import check_writable
from irl_core.studies.study import LoadedStudy, load_study
from irl_core.support.safe_files import write_problem
from irl_core.support.safe_text import printable

if TYPE_CHECKING:
    from careful_tui.web.serving_lock import ServingLock

_COMPLETION_CODE = re.compile(r"[A-Za-z0-9_-]{1,40}")


def say(line: str) -> None:
    """A line for the experimenter, at once (the server's console is often a log)."""
    print(printable(line), flush=True)


def run_serve(args: argparse.Namespace) -> int:
    """`careful serve STUDY.toml [--host H] [--port N] [--links N] [--completion-code CODE] [--workers N]
    [--forwarded-allow-ips IPS]`."""
    from careful_tui.web.links import MOST_LINKS, add_links, read_links
    from careful_tui.web.server import make_app
    from careful_tui.web.serving_lock import hold_out_folder
    from careful_tui.web.workers import most_workers

    if not args.host.strip():
        raise UsageError("--host needs an address: 127.0.0.1 (this machine only) or 0.0.0.0 (every interface)")
    if args.workers > most_workers():
        raise UsageError(f"--workers {args.workers} is more than this machine can use (at most {most_workers()}: "
                         "4 per core)")
    if args.links > MOST_LINKS:
        raise UsageError(f"--links {args.links:,} is more than one start may add ({MOST_LINKS:,}); add them in parts")
    proxies = forwarded_allow_ips(args.forwarded_allow_ips)

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
    # Before anything is written in the out folder (links, seats), and before the port (a second start of the
    # same command is told which server holds the folder, not only that the port is taken).
    held = hold_out_folder(study)
    try:
        sock = bind(args.host, args.port)
    except UsageError:
        held.release()
        raise
    try:
        held.name_address(base_url(args.host, sock))
        new = add_links(study, args.links) if args.links else []
        links = read_links(study)
    except (UsageError, LinksError) as exc:
        sock.close()
        held.release()
        raise UsageError(str(exc)) from None
    prolific = args.prolific or not links
    if args.workers > 1:
        return serve_workers(args, study, sock, held, new=new, links=links, prolific=prolific, proxies=proxies)
    server = make_server(make_app(study, links=links, completion_code=args.completion_code, say=say, prolific=prolific),
                         forwarded_allow_ips=proxies)
    # From the first line on, Ctrl+C or SIGTERM is a stop (before uvicorn runs, and while it runs).
    stopping = {sig: signal.signal(sig, lambda *_: setattr(server, "should_exit", True))
                for sig in (signal.SIGINT, signal.SIGTERM)}
    try:
        announce(args, study, sock, new=new, links=links, prolific=prolific, proxies=proxies)
        server.run(sockets=[sock])
    finally:
        for sig, handler in stopping.items():
            signal.signal(sig, handler)
        held.release()
    say("careful serve: stopped; every recording is closed")
    return 0


def serve_workers(args: argparse.Namespace, study: LoadedStudy, sock: socket.socket, held: ServingLock, *,
                  new: list[tuple[str, str]], links: dict[str, str], prolific: bool, proxies: tuple[str, ...]) -> int:
    """`--workers N` > 1: the worker processes on `sock` (`careful_tui.web.workers`) until Ctrl+C; the study and
    its links as read here, once."""
    from careful_tui.web.workers import WorkerSettings, new_key, supervise

    settings = WorkerSettings(study=study, links=links, completion_code=args.completion_code, prolific=prolific,
                              key=new_key(), forwarded_allow_ips=proxies)
    announce(args, study, sock, new=new, links=links, prolific=prolific, proxies=proxies)
    say(f"workers: {args.workers} processes; the pages' seats in {study.out}/.<participant>.seat")
    try:
        code = supervise(settings, sock, workers=args.workers, say=say, make_server=make_server, held=held)
    finally:
        held.release()
    sock.close()
    say("careful serve: stopped; every recording is closed" if code == 0 else "careful serve: stopped")
    return code


def forwarded_allow_ips(value: str | None) -> tuple[str, ...]:
    """`--forwarded-allow-ips`: the proxies (addresses or networks) whose X-Forwarded-For names the client;
    none by default, so no client chooses the address its budget of new pages is counted under."""
    if value is None:
        return ()
    items = tuple(item.strip() for item in value.split(","))
    if "*" in items:
        raise UsageError("--forwarded-allow-ips '*' would let any client choose its own address; name the proxy's "
                         "(127.0.0.1 for a proxy on this machine)")
    for item in items:
        try:
            ipaddress.ip_network(item)  # strict, as uvicorn reads it: 10.0.0.1/8 is no network
        except ValueError:
            raise UsageError(f"--forwarded-allow-ips takes IP addresses or networks, separated by commas "
                             f"(127.0.0.1, 10.0.0.0/8), not {printable(item, limit=80)!r}") from None
    return items


def base_url(host: str, sock: socket.socket) -> str:
    """The server's address, as a browser on this machine reaches it."""
    return f"http://{host if ':' not in host else f'[{host}]'}:{sock.getsockname()[1]}"


def announce(args: argparse.Namespace, study: LoadedStudy, sock: socket.socket, *, new: list[tuple[str, str]],
             links: dict[str, str], prolific: bool, proxies: tuple[str, ...]) -> None:
    """The experimenter's first lines: where the study is served, the links, Prolific, the client addresses, the
    recordings."""
    from careful_tui.web.links import LINKS_FILE, link_path

    base = base_url(args.host, sock)
    say(f"careful serve: study {study.study.name!r} at {base}/ (Ctrl+C stops)")
    if new:
        say(f"links: {len(new)} new appended to {study.out / LINKS_FILE}, {len(links)} in all")
    elif links:
        say(f"links: {len(links)} in {study.out / LINKS_FILE}")
    for participant, token in new[:3]:
        say(f"  {participant}: {base}{link_path(token)}")
    say(prolific_line(base, args.completion_code) if prolific else
        "Prolific: off (links only; --prolific also takes Prolific links, as participants of their own)")
    if proxies:
        say(f"client addresses: from X-Forwarded-For when the request comes from {', '.join(proxies)}")
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


def make_server(app, *, header_timeout_s: float | None = None, forwarded_allow_ips: tuple[str, ...] = (),
                on_started: Callable[[], None] | None = None):
    """The uvicorn server for `app`: Ctrl+C (or SIGTERM) stops it taking requests, then the app's
    shutdown closes every participant's file. Run it with ``.run(sockets=[bind(...)])``; it
    returns once stopped; `on_started` is called once it serves.

    Connections are bounded (`connection_limit`: 503 beyond), and each request head must arrive
    within `header_timeout_s` (`careful_tui.web.guarded_http`). A request's client address (what the
    budget of new pages counts) is its peer's, or the X-Forwarded-For a proxy in `forwarded_allow_ips`
    sends (its last address not one of them): uvicorn's own default trusts it from any loopback peer."""
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

        async def startup(self, sockets: list[socket.socket] | None = None) -> None:
            await super().startup(sockets=sockets)
            if self.started and on_started is not None:
                on_started()

    config = uvicorn.Config(app, log_level="warning", access_log=False, lifespan="on", timeout_graceful_shutdown=3,
                            server_header=False, http=Protocol, limit_concurrency=connection_limit(),
                            proxy_headers=bool(forwarded_allow_ips), forwarded_allow_ips=list(forwarded_allow_ips))
    return Server(config)


def connection_limit() -> int:
    """Connections served at once: half of what the open-file limit leaves (seats take the rest)."""
    import resource

    from careful_tui.web.seats import FILES_KEPT, MOST_SEATS

    soft, _ = resource.getrlimit(resource.RLIMIT_NOFILE)
    room = 4 * MOST_SEATS if soft == resource.RLIM_INFINITY else (soft - FILES_KEPT) // 2
    return max(16, min(4 * MOST_SEATS, room))
