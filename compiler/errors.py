"""The compiler's one exception: a broken invariant, not a problem of the program."""

from __future__ import annotations


class InternalCompilerError(Exception):
    """An invariant the checker guarantees does not hold: a bug, not a user error."""
