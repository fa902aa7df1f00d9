"""``morphogen serve``: the web app (Explore, Atlas, Evolve, Runs, Mesh) on a local port."""

from __future__ import annotations

import argparse
import ipaddress
import os
import socket

from morphogen.errors import MorphogenError
from morphogen.util.extras import require

LOCAL = ("127.0.0.1", "localhost", "::1")


def register(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser(
        "serve",
        help="start the web app",
        description="Serve the web app on http://HOST:PORT/ (127.0.0.1 by default, so only this "
        "machine can reach it). Stop it with Ctrl-C.",
    )
    p.add_argument("--port", type=int, default=8000, help="TCP port (default 8000; 0 = any free)")
    p.add_argument("--host", default="127.0.0.1",
                   help="address to bind (default 127.0.0.1; an address beyond this machine "
                   "needs --allow-remote)")
    p.add_argument("--allow-remote", action="store_true",
                   help="serve on a --host other machines can reach; every request then needs "
                   "the access token printed at start ($MORPHOGEN_TOKEN, or a random one)")
    p.add_argument("--archive", default=None,
                   help="run archive (SQLite index) shared with `morphogen evolve` "
                   "(default: $MORPHOGEN_ARCHIVE or runs/index.sqlite)")
    p.add_argument("--no-warm-up", dest="warm_up", action="store_false",
                   help="do not compile the library models' live views in the background at "
                   "start (they are compiled on first use instead)")
    p.add_argument("--examples", default=None, metavar="DIR",
                   help="where the Mesh page's case studies are (DIR/flowers/*.toml; default: "
                   "the repository's examples/)")
    p.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    require("fastapi", "web", "morphogen serve")
    uvicorn = require("uvicorn", "web", "morphogen serve")

    from morphogen.web.app import LOCAL_HOSTS, create_app

    if not 0 <= args.port <= 65535:
        raise MorphogenError(f"--port must be between 0 and 65535, got {args.port}")
    from morphogen.web.guards import server_options
    from morphogen.web.limits import Limits

    hosts, token = access(args.host, args.allow_remote)
    check_archive(args.archive)
    limits = Limits()
    app = create_app(limits=limits, archive=args.archive, allowed_hosts=hosts or LOCAL_HOSTS,
                     warm_up=args.warm_up, examples=args.examples, token=token)
    family = socket.AF_INET6 if ":" in args.host else socket.AF_INET
    sock = socket.socket(family, socket.SOCK_STREAM)
    sock.setsockopt(socket.SOL_SOCKET, socket.SO_REUSEADDR, 1)
    try:
        sock.bind((args.host, args.port))
    except OSError as exc:
        sock.close()
        raise MorphogenError(
            f"cannot listen on {args.host}:{args.port}: {exc.strerror}; choose another --port"
        ) from None
    port = sock.getsockname()[1]
    server = uvicorn.Server(uvicorn.Config(app, log_level="warning", ws="websockets-sansio",
                                           **server_options(limits)))
    where = f"http://{_url_host(args.host)}:{port}/" + (f"?token={token}" if token else "")
    print(f"morphogen web app on {where} (Ctrl-C to stop)", flush=True)
    try:
        server.run(sockets=[sock])
    finally:
        sock.close()
    return 0


def check_archive(path: str | None) -> None:
    """Refuse at start a run archive the Runs and Evolve pages could not use: a device, FIFO
    or folder, or a file that is not a readable SQLite index (an absent one is made by the
    first run)."""
    from morphogen.search.archive import Archive, archive_path

    if os.path.lexists(archive_path(path)):
        Archive(path, create=False)


def is_local(host: str) -> bool:
    """Whether ``host`` is this machine only (``localhost`` or a loopback address)."""
    if host in LOCAL:
        return True
    try:
        return ipaddress.ip_address(host.strip("[]")).is_loopback
    except ValueError:
        return False


def access(host: str, allow_remote: bool) -> tuple[list[str] | None, str | None]:
    """``(allowed Host headers, access token)`` for serving on ``host``: on this machine the
    default names and no token; beyond it only with ``allow_remote``, any name and a token
    (``$MORPHOGEN_TOKEN`` or a random one), which replaces the Host check."""
    if is_local(host):
        return None, None
    if not allow_remote:
        raise MorphogenError(
            f"--host {host} lets other machines reach the app; add --allow-remote to serve "
            "there (every request then needs the access token printed at start)")
    from morphogen.web.guards import new_token

    token = os.environ.get("MORPHOGEN_TOKEN") or new_token()
    if len(token) < 16 or not all(c.isalnum() or c in "-_" for c in token):
        raise MorphogenError("$MORPHOGEN_TOKEN must be at least 16 letters, digits, - or _")
    return ["*"], token


def _url_host(host: str) -> str:
    return f"[{host}]" if ":" in host else host
