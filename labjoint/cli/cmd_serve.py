"""`labjoint serve --host H --port P [--no-daemon]`: the REST service."""

from __future__ import annotations

import argparse


def add_serve_arguments(p: argparse.ArgumentParser) -> None:
    p.add_argument("--host", default=None, help="bind address (default 127.0.0.1)")
    p.add_argument("--port", type=int, default=None, help="TCP port (default 8000)")
    p.add_argument("--no-daemon", action="store_true",
                   help="attach to a separately running daemon through the job queue")
    p.add_argument("--data", default=None, help="data directory (default: the config's data_dir)")


def run(args: argparse.Namespace) -> int:
    from labjoint.api.server import serve

    serve(args.config, args.host, args.port, daemon=not args.no_daemon, data_dir=args.data)
    return 0
