"""What a program file is called: the file-name suffixes that rapidc reads as programs.

One place for the CLI (which files a folder stands for) and module resolution (which files a `use`
may name). Imports nothing, so every command may import it at start-up.
"""

from __future__ import annotations

RAPID_SUFFIXES = (".rapid",)
YAML_SUFFIXES = (".rapid.yaml", ".rapid.yml")
SOURCE_SUFFIXES = RAPID_SUFFIXES + YAML_SUFFIXES


def is_program_name(name: str) -> bool:
    return name.endswith(SOURCE_SUFFIXES)
