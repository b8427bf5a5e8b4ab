"""`rapidc guide`: print the language card, what an agent reads before writing a program.

The card (frontend/card.py) is generated from the registry, the standard library and the checker,
and is also the MCP resource `rapid://card`.
"""

from __future__ import annotations

import argparse
import sys
from typing import Any


def add_parser(subparsers: Any) -> argparse.ArgumentParser:
    return subparsers.add_parser(
        "guide", help="print the compact language card (for coding agents)",
        description="Print the RAPID language card as Markdown: the syntax of primitives and "
                    "strategies, kinds, units, the builtins with their signatures, the standard "
                    "primitives with their params, and common errors with their fixes.")


def run(args: argparse.Namespace) -> int:
    from rapid_dsl.frontend.card import card

    sys.stdout.write(card())
    return 0
