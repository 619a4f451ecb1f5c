"""knitc's language server (`knitc lsp`): the compiler's diagnostics, hover, completion,
navigation, formatting and a preview in the designer's editor, over the Language Server
Protocol (pygls). `server.create_server` builds it; `main` runs it on stdio or TCP.
See docs/editors.md for connecting an editor and docs/architecture.md for the design."""

from __future__ import annotations

import argparse
import logging


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(
        prog="knitc lsp",
        description="Run knitc's language server (stdio by default), for an editor to start.",
    )
    parser.add_argument("--stdio", action="store_true", help="talk on stdin/stdout (default)")
    parser.add_argument("--tcp", action="store_true", help="listen on a TCP port instead")
    parser.add_argument("--host", default="127.0.0.1", help="--tcp: address (127.0.0.1)")
    parser.add_argument("--port", type=int, default=2087, help="--tcp: port (2087)")
    parser.add_argument("--log-file", metavar="FILE", help="write the server's log to FILE")
    args = parser.parse_args(argv)
    if args.log_file:
        logging.basicConfig(filename=args.log_file, level=logging.INFO)
    from knitc.lsp.server import create_server

    server = create_server()
    try:
        if args.tcp:
            server.start_tcp(args.host, args.port)
        else:
            server.start_io()
    finally:
        server.backend.close()
    return 0
