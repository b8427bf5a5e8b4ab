"""`rapidc lsp`: run the language server for editors (docs/editors.md), LSP on standard input and
output. Needs the `lsp` extra: `pip install 'rapid-dsl[lsp]'`.

Documents are checked from the editor's text; the files they `use` are read from disk under the
same rules as `rapidc check` (docs/security.md), widened only by `--allow-path` here, never by the
editor or a workspace's settings.
"""

from __future__ import annotations

import argparse
from typing import Any

from rapid_dsl.commands.common import add_input_options, fail_usage


def add_parser(subparsers: Any) -> argparse.ArgumentParser:
    parser = subparsers.add_parser(
        "lsp", help="run the language server for editors (LSP over stdio)",
        description="Run the RAPID language server: diagnostics as you type, hover, go to "
                    "definition, completion and formatting for .rapid and YAML programs. It talks "
                    "LSP on standard input and output; an editor starts it (docs/editors.md). "
                    "Exit status 0 after the client's shutdown request, 1 without one.")
    parser.add_argument("--stdio", action="store_true",
                        help="talk on standard input and output (the default and only transport; "
                             "accepted because editor clients pass it)")
    add_input_options(parser)
    return parser


def run(args: argparse.Namespace) -> int:
    try:
        from rapid_dsl.lsp.server import serve
    except ModuleNotFoundError as exc:
        missing = (exc.name or "").split(".")[0]
        if missing not in ("pygls", "lsprotocol"):
            raise
        return fail_usage(f"rapidc lsp needs {missing}: pip install 'rapid-dsl[lsp]'")
    return serve(args.allowed_dirs)
