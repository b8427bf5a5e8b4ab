"""`rapidc mcp`: serve the compiler, runner and verifier as MCP tools over stdio (docs/agents.md).

Needs the optional extra `rapid-dsl[mcp]` (the `mcp` SDK). The server runs until its client closes
standard input; its own messages go to stderr (standard output carries the protocol).
Exit status: 0 when the client closed the connection, 2 bad options or no `mcp` package.
"""

from __future__ import annotations

import argparse
import os
from typing import Any

from rapid_dsl.commands.common import add_input_options, fail_usage, folder, positive_int
from rapid_dsl.commands.verify import MAX_JOBS


def add_parser(subparsers: Any) -> argparse.ArgumentParser:
    parser = subparsers.add_parser(
        "mcp", help="serve check, run, verify, ... as Model Context Protocol tools over stdio",
        description="Serve rapidc's commands as MCP tools (check, lint, fmt, compile, bind, run, "
                    "verify, variants, explain) and the language reference, builtins, standard "
                    "library, diagnostics and language card as resources, over stdio, for coding "
                    "agents. Every path a tool call names must lie in ROOT or an --allow-path "
                    "folder.",
        epilog="Register it with an agent: docs/agents.md. Needs `pip install 'rapid-dsl[mcp]'`.")
    parser.add_argument("--root", type=folder, default=".", metavar="DIR",
                        help="the folder tool calls work in: relative paths start there, and "
                             "paths must stay in it (default: the current folder)")
    parser.add_argument("--workers", type=positive_int, metavar="N",
                        help="run at most N worker processes at once (run, variants, and verify "
                             "with one per job); later calls wait for their turn (default: one "
                             f"per core; at most {MAX_JOBS})")
    add_input_options(parser)
    return parser


def run(args: argparse.Namespace) -> int:
    try:
        import anyio

        from rapid_dsl.mcp.server import serve
    except ImportError as exc:
        return fail_usage(f"`rapidc mcp` needs the MCP SDK ({exc}); install it with "
                          "pip install 'rapid-dsl[mcp]'")
    from pathlib import Path

    from rapid_dsl.mcp.arguments import Workspace
    from rapid_dsl.mcp.slots import default_workers
    from rapid_dsl.runtime.gl import backend

    if args.workers is not None and args.workers > MAX_JOBS:
        return fail_usage(f"--workers {args.workers}: at most {MAX_JOBS}")

    root = Path(args.root).resolve()
    os.chdir(root)   # tool calls' relative paths, as a shell in ROOT would read them
    workspace = Workspace(root, tuple(str(Path(d).resolve()) for d in args.allowed_dirs))
    anyio.run(serve, workspace, backend(), args.workers or default_workers())
    return 0
