"""`rapidc mcp` answers every line with an id, whatever it holds, and goes on serving: lines the
SDK's client would never send, written to the server's stdin as raw bytes (wire.py)."""

from __future__ import annotations

import itertools
import json
from collections.abc import Iterator
from typing import Any

import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st
from wire import Wire

PARSE_ERROR, INVALID_REQUEST = -32700, -32600     # JSON-RPC's codes
MAX_FRAME_BYTES = 64 * 1024 * 1024                # docs/security.md


@pytest.fixture(scope="module")
def wire(tmp_path_factory: pytest.TempPathFactory) -> Iterator[Wire]:
    server = Wire(tmp_path_factory.mktemp("wire"))
    try:
        server.initialize()
        yield server
    finally:
        assert server.close() == 0
        assert "Traceback" not in server.stderr()


def _call(key: Any, arguments: str) -> bytes:
    """A tools/call of explain whose arguments are the raw JSON text `arguments`."""
    return (b'{"jsonrpc": "2.0", "id": ' + json.dumps(key).encode()
            + b', "method": "tools/call", "params": {"name": "explain", "arguments": '
            + arguments.encode() + b"}}\n")


def _error(wire: Wire, key: Any) -> dict[str, Any]:
    answer = wire.answer(key)
    assert "error" in answer, answer
    error: dict[str, Any] = answer["error"]
    return error


@pytest.mark.slow
def test_a_lone_surrogate_is_an_invalid_request(wire: Wire) -> None:
    # The SDK's reader refuses the line and drops it: the client used to wait forever.
    wire.send_bytes(_call(1, '{"code": "\\ud800"}'))
    error = _error(wire, 1)
    assert error["code"] == INVALID_REQUEST
    assert error["message"] == ("the message holds a lone surrogate (\\ud800), which is not "
                                "Unicode text")
    wire.send_bytes(_call("\udc00 id", '{"code": "E0101"}'))     # even in the id itself
    assert wire.unnamed_answer()["error"]["code"] == INVALID_REQUEST
    assert wire.request(2, "ping")["result"] == {}


@pytest.mark.parametrize("depth", [65, 5000])
def test_deep_nesting_is_an_invalid_request(wire: Wire, depth: int) -> None:
    wire.send_bytes(_call(f"deep {depth}", '{"code": ' + "[" * depth + "]" * depth + "}"))
    error = _error(wire, f"deep {depth}")
    assert (error["code"], error["message"]) == (INVALID_REQUEST,
                                                 "the message nests deeper than 64 levels")
    assert wire.request(3, "ping")["result"] == {}


def test_lines_that_are_not_messages_are_answered(wire: Wire) -> None:
    wire.send_bytes(b'{"jsonrpc": "2.0", "id": 4, "method": "tools/call", "params": {oops\n')
    error = _error(wire, 4)
    assert error["code"] == PARSE_ERROR and error["message"].startswith("the message is not JSON")
    wire.send_bytes(b'{"jsonrpc": "2.0", "id": 5, "method": "ping", "params": "\xff"}\n')
    assert _error(wire, 5) == {"code": PARSE_ERROR,
                               "message": "the message is not UTF-8 text (byte 58)"}
    wire.send_bytes(b'{"jsonrpc": "2.0", "id": 6}\n')
    assert _error(wire, 6)["code"] == INVALID_REQUEST
    wire.send_bytes(b"[1, 2]\n")
    assert wire.unnamed_answer()["error"]["code"] == INVALID_REQUEST
    wire.send_bytes(b"\n  \r\n")     # blank lines are skipped
    assert wire.request(7, "ping")["result"] == {}


def test_a_line_over_the_limit_is_dropped_and_answered(wire: Wire) -> None:
    wire.send_bytes(_call(8, '{"code": "' + "x" * MAX_FRAME_BYTES + '"}'))
    assert _error(wire, 8) == {"code": INVALID_REQUEST, "message": "a message is at most 64 MiB"}
    assert wire.request(9, "ping")["result"] == {}


# ------------------------------------------------------------------------- hostile lines

_SURROGATES = st.characters(min_codepoint=0xD800, max_codepoint=0xDFFF, categories=["Cs"])
_TEXT = st.text(st.one_of(st.characters(), _SURROGATES), max_size=12)
_JSON = st.recursive(st.none() | st.booleans() | st.integers() | st.floats() | _TEXT,
                     lambda inner: st.lists(inner, max_size=4)
                     | st.dictionaries(_TEXT, inner, max_size=4), max_leaves=12)
_METHODS = st.sampled_from(["ping", "tools/list", "tools/call", "resources/list",
                            "resources/read", "no/such"]) | _TEXT
_TOOLS = st.sampled_from(["explain", "check", "lint", "fmt", "compile"]) | _TEXT
_PARAMS = st.one_of(_JSON, st.fixed_dictionaries(
    {"name": _TOOLS, "arguments": st.dictionaries(_TEXT, _JSON, max_size=3)}))
_DAMAGE = st.sampled_from(["none", "cut", "deep", "bytes", "id"])
_keys = itertools.count(1000)
EXAMPLES = 150


@pytest.mark.slow
@settings(max_examples=EXAMPLES, deadline=None,
          suppress_health_check=[HealthCheck.too_slow, HealthCheck.data_too_large])
@given(method=_METHODS, params=_PARAMS, damage=_DAMAGE, at=st.floats(0, 1),
       depth=st.integers(1, 3000), suffix=_TEXT)
def test_every_request_is_answered_and_the_server_goes_on(
        wire: Wire, method: str, params: Any, damage: str, at: float, depth: int,
        suffix: str) -> None:
    key: Any = next(_keys)
    if damage == "id":
        key = f"{key} {suffix}"      # a string id, which may hold a lone surrogate
    line = json.dumps({"jsonrpc": "2.0", "id": key, "method": method, "params": params})
    data = line.encode()
    if damage == "cut":
        data = data[:int(len(data) * at)]
    elif damage == "deep":
        data = data.replace(b'"params": ', b'"params": ' + b"[" * depth, 1) + b"]" * depth
    elif damage == "bytes":
        cut = int(len(data) * at)
        data = data[:cut] + b"\xc3\x28\xff" + data[cut:]
    wire.send_bytes(data + b"\n")
    probe = next(_keys)
    assert wire.request(probe, "ping")["result"] == {}, "the server stopped serving"
    if not data:
        return      # a blank line: skipped
    # the request itself: answered by its id, or by null when the id cannot be read back
    answer = wire.wait(lambda: wire.answers.pop(key, None)
                       or (wire.unnamed.pop(0) if wire.unnamed else None), timeout=10)
    assert "result" in answer or "error" in answer
    if damage == "none" and "error" in answer:
        assert answer["id"] == key
    wire.unnamed.clear()
