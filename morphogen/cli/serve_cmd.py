"""``morphogen serve``: the web app (Explore, Atlas, Evolve, Runs, Mesh) on a local port."""

from __future__ import annotations

import argparse
import socket

from morphogen.errors import MorphogenError

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
                   help="address to bind (default 127.0.0.1; anything else exposes the app to "
                   "the network)")
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
    import uvicorn

    from morphogen.web.app import LOCAL_HOSTS, create_app

    if not 0 <= args.port <= 65535:
        raise MorphogenError(f"--port must be between 0 and 65535, got {args.port}")
    hosts = list(LOCAL_HOSTS)
    if args.host not in LOCAL:
        hosts.append(args.host)
        print(f"warning: serving on {args.host}; anyone who can reach it can use the app")
    app = create_app(archive=args.archive, allowed_hosts=hosts,
                     warm_up=args.warm_up, examples=args.examples)
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
    server = uvicorn.Server(uvicorn.Config(app, log_level="warning", ws="websockets-sansio"))
    print(f"morphogen web app on http://{_url_host(args.host)}:{port}/ (Ctrl-C to stop)",
          flush=True)
    try:
        server.run(sockets=[sock])
    finally:
        sock.close()
    return 0


def _url_host(host: str) -> str:
    return f"[{host}]" if ":" in host else host
