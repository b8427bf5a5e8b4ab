"""JSON-RPC 2.0 messages from an untrusted peer, read the same way by both servers.

`rapidc mcp` (a message per line) and `rapidc lsp` (a message per Content-Length frame) hand each
message's bytes to `read` before their protocol library sees them, so that every request gets an
answer, even one the library would drop: bytes that are not UTF-8 text or not JSON are a parse
error (-32700); JSON that is not one JSON-RPC message, that nests deeper than MAX_NESTING, or (where
the peer's library cannot carry it: MCP) that holds a lone surrogate is an invalid request
(-32600). The error carries the request's id when it can be read: from the parsed message, or, from
text that does not parse, from the members before the first nested value (where clients put it);
otherwise null, as JSON-RPC says.
"""

from __future__ import annotations

import json
import re
from typing import Any

from rapid_dsl.language.safe_json import depth

MAX_FRAME_BYTES = 64 * 1024 * 1024   # one message; far above a 10 MiB program sent as text
MAX_NESTING = 64                     # objects and arrays; real messages nest fewer than 10

PARSE_ERROR = -32700
INVALID_REQUEST = -32600
INVALID_PARAMS = -32602
INTERNAL_ERROR = -32603

Id = str | int | None

_STRING = r'"(?:[^"\\]|\\.)*"'
_SCALAR = rf'(?:{_STRING}|-?\d+(?:\.\d+)?(?:[eE][-+]?\d+)?|true|false|null)'
# `{"jsonrpc": "2.0", "id": 7, "method": ...`: an id after scalar members only
_LEADING_ID = re.compile(rf'\s*\{{\s*(?:{_STRING}\s*:\s*{_SCALAR}\s*,\s*)*"id"\s*:\s*'
                         rf'({_STRING}|-?\d+)\s*[,}}]')
_SURROGATE = re.compile("[\ud800-\udfff]")


class Invalid(ValueError):
    """A message that cannot be handled; `response()` is the error that answers it."""

    def __init__(self, code: int, message: str, id: Id = None) -> None:  # noqa: A002 - JSON-RPC's
        super().__init__(message)
        self.code = code
        self.message = message
        self.id = id

    def response(self) -> dict[str, Any]:
        return error_response(self.id, self.code, self.message)


def error_response(id: Id, code: int, message: str) -> dict[str, Any]:  # noqa: A002
    return {"jsonrpc": "2.0", "id": id, "error": {"code": code, "message": message}}


def read(frame: bytes, *, unicode_only: bool = False) -> dict[str, Any]:
    """The message in `frame`, or Invalid. `unicode_only`: a lone surrogate (a `\\ud800` escape)
    makes the message invalid, for peers whose library cannot read or write one."""
    try:
        text = frame.decode("utf-8")
    except UnicodeDecodeError as exc:
        raise Invalid(PARSE_ERROR, f"the message is not UTF-8 text (byte {exc.start + 1})",
                      recover_id(frame.decode("utf-8", "replace"), unicode_only)) from None
    if depth(text) > MAX_NESTING:   # measured before the parser recurses
        raise Invalid(INVALID_REQUEST, f"the message nests deeper than {MAX_NESTING} levels",
                      recover_id(text, unicode_only))
    try:
        value = json.loads(text)
    except ValueError as exc:
        raise Invalid(PARSE_ERROR, f"the message is not JSON: {_reason(exc)}",
                      recover_id(text, unicode_only)) from None
    if not isinstance(value, dict):
        raise Invalid(INVALID_REQUEST, "a message is one JSON object (batches are not supported)")
    id_ = value.get("id")
    if isinstance(id_, bool) or not isinstance(id_, str | int | None):
        raise Invalid(INVALID_REQUEST, "a message's id is a string, an integer or null")
    if unicode_only and isinstance(id_, str) and _SURROGATE.search(id_):
        id_ = None
    problem = _problem(value, unicode_only)
    if problem is None and value.get("jsonrpc") != "2.0":
        problem = 'a message says "jsonrpc": "2.0"'
    if problem is None and "method" in value and not isinstance(value["method"], str):
        problem = "a message's method is a string"
    if problem is None and "method" not in value and "id" not in value:
        problem = "a message is a request, a notification or a response"
    if problem is not None:
        raise Invalid(INVALID_REQUEST, problem, id_)
    return value


def recover_id(text: str, unicode_only: bool = False) -> Id:
    """The id of a message that does not parse, if it comes before any nested member."""
    match = _LEADING_ID.match(text)
    if match is None:
        return None
    try:
        value = json.loads(match.group(1))
    except ValueError:
        return None
    if not isinstance(value, str | int) or isinstance(value, bool):
        return None
    if unicode_only and isinstance(value, str) and _SURROGATE.search(value):
        return None
    return value


def _problem(value: Any, unicode_only: bool) -> str | None:
    """Why a parsed message cannot be handled: a lone surrogate (`unicode_only`)."""
    if not unicode_only:
        return None
    stack: list[Any] = [value]
    while stack:
        item = stack.pop()
        children = item.items() if isinstance(item, dict) else enumerate(item)
        for key, child in children:
            for text in (key, child):
                if unicode_only and isinstance(text, str) and not text.isascii() \
                        and (found := _SURROGATE.search(text)) is not None:
                    return (f"the message holds a lone surrogate (\\u{ord(found.group()):04x}), "
                            "which is not Unicode text")
            if isinstance(child, dict | list):
                stack.append(child)
    return None


def _reason(exc: ValueError) -> str:
    if isinstance(exc, json.JSONDecodeError):
        return f"{exc.msg} at line {exc.lineno}, column {exc.colno}"
    return str(exc)
