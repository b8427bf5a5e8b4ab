"""`rapidc lsp` answers every request and goes on serving, whatever the client sends: frames with
bad headers, bodies that are not messages, positions that are not positions, URIs that name no
file, requests after `shutdown`; and a large document holds up no request about another."""

from __future__ import annotations

import itertools
import json
import time
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from rapid_dsl.bench.check import generate_strategy_file

from .client import Client, ServerError
from .conftest import make_project

PARSE_ERROR, INVALID_REQUEST, INVALID_PARAMS = -32700, -32600, -32602   # JSON-RPC's codes
SMALL = "relation near(a: Body, b: Body) = distance(a, b) < 1cm\n"


@pytest.fixture(scope="module")
def hostile(tmp_path_factory: pytest.TempPathFactory) -> Iterator[tuple[Client, str]]:
    """A server of this module's own (these tests send what may upset it), with one document
    open: its URI."""
    project = make_project(tmp_path_factory.mktemp("hostile"))
    client = Client(cwd=project)
    try:
        client.initialize(project)
        uri = client.open(project / "small.rapid", SMALL)
        assert client.diagnostics(uri) == []
        yield client, uri
        assert "internal error" not in client.stderr() if client.process.poll() else True
    finally:
        if client.process.poll() is None:
            client.close()


def _hover(key: Any, uri: str, position: Any) -> bytes:
    return json.dumps({"jsonrpc": "2.0", "id": key, "method": "textDocument/hover",
                       "params": {"textDocument": {"uri": uri}, "position": position}}).encode()


def _frame(body: bytes, header: bytes | None = None) -> bytes:
    return (b"Content-Length: %d\r\n" % len(body) if header is None else header) + b"\r\n" + body


def _serves(client: Client, uri: str) -> None:
    """The server answers a hover on the open document (after any answers to what came
    before: those are dropped)."""
    hover = client.request("textDocument/hover", {"textDocument": {"uri": uri},
                                                  "position": {"line": 0, "character": 36}})
    assert "distance(a: Body, b: Body) -> Length" in hover["contents"]["value"]
    client.unnamed.clear()


# -------------------------------------------------------------------------------- headers

@pytest.mark.parametrize("header", [
    b"Content-Length: 99999999999999999999\r\n",      # pygls: OverflowError
    b"Content-Length: -1\r\n",                        # pygls: never answered again
    b"Content-Length: abc\r\n",
    b"Content-Length:\r\n",
    b"Content-Type: application/vscode-jsonrpc; charset=utf-8\r\n",   # no length at all
    b"Content-Length: 12\r\nContent-Length: 13\r\n",
    b"X-Padding: " + b"x" * 10_000 + b"\r\n",
], ids=["huge", "negative", "not-a-number", "empty", "missing", "twice", "long-line"])
@pytest.mark.slow
def test_a_frame_with_a_bad_header_is_answered_and_skipped(hostile: tuple[Client, str],
                                                           header: bytes) -> None:
    client, uri = hostile
    client.send_bytes(_frame(_hover("lost", uri, {"line": 0, "character": 0}), header))
    error = client.response(None)["error"]
    assert error["code"] == (INVALID_REQUEST if b"999" in header else PARSE_ERROR), error
    _serves(client, uri)
    assert "lost" not in client.responses      # its body was skipped, not read as a request


def test_a_frame_over_the_size_limit_is_answered_and_skipped(hostile: tuple[Client, str]) -> None:
    client, uri = hostile
    client.send_bytes(_frame(b"{}", b"Content-Length: %d\r\n" % (64 * 1024 * 1024 + 1)))
    assert client.response(None)["error"] == {"code": INVALID_REQUEST,
                                              "message": "a message is at most 64 MiB"}
    _serves(client, uri)


def test_a_length_shorter_than_its_body_costs_that_frame_only(
        hostile: tuple[Client, str]) -> None:
    client, uri = hostile
    body = _hover("short", uri, {"line": 0, "character": 0})
    client.send_bytes(_frame(body, b"Content-Length: %d\r\n" % (len(body) - 5)))
    assert client.response("short")["error"]["code"] == PARSE_ERROR   # the id read back
    _serves(client, uri)


# --------------------------------------------------------------------------------- bodies

def test_bodies_that_are_not_messages_are_answered(hostile: tuple[Client, str]) -> None:
    client, uri = hostile
    client.send_bytes(_frame(b'{"jsonrpc": "2.0", "id": "cut", "method": "textDocument/ho'))
    error = client.response("cut")["error"]
    assert error["code"] == PARSE_ERROR and error["message"].startswith("the message is not JSON")
    deep = b"[" * 5000 + b"]" * 5000
    client.send_bytes(_frame(b'{"jsonrpc": "2.0", "id": "deep", "method": "textDocument/hover",'
                             b' "params": ' + deep + b"}"))
    assert client.response("deep")["error"] == {
        "code": INVALID_REQUEST, "message": "the message nests deeper than 64 levels"}
    client.send_bytes(_frame(b'{"jsonrpc": "1.0", "id": "old", "method": "shutdown"}'))
    assert client.response("old")["error"]["code"] == INVALID_REQUEST
    client.send_bytes(_frame(b"[1, 2]"))
    assert client.response(None)["error"]["code"] == INVALID_REQUEST
    client.send_bytes(_frame(b'{"jsonrpc": "2.0", "id": "bytes", "method": "\xff"}'))
    assert client.response("bytes")["error"]["code"] == PARSE_ERROR
    _serves(client, uri)


@pytest.mark.parametrize("position, message", [
    ({"line": -1, "character": 0}, "Position.line should be in range [0:2147483647], but was -1"),
    ({"line": 2**40, "character": 0}, "but was 1099511627776"),
    ({"line": 0, "character": -3}, "Position.character should be in range"),
    ({"line": "abc", "character": 0}, "$.params.position.line"),
    (None, "$.params.position"),
])
def test_a_position_that_is_not_one_is_invalid_params(hostile: tuple[Client, str],
                                                      position: Any, message: str) -> None:
    client, uri = hostile
    with pytest.raises(ServerError) as raised:
        client.request("textDocument/hover", {"textDocument": {"uri": uri},
                                              "position": position}, timeout=10)
    error = raised.value.args[0]
    assert error["code"] == INVALID_PARAMS and message in error["message"], error
    _serves(client, uri)


def test_a_uri_that_names_no_file(hostile: tuple[Client, str], tmp_path: Path) -> None:
    client, uri = hostile
    bad = tmp_path.as_uri() + "/a%00b.rapid"
    client.notify("textDocument/didOpen", {"textDocument": {
        "uri": bad, "languageId": "rapid", "version": 1, "text": SMALL}})
    [diagnostic] = client.diagnostics(bad)
    assert diagnostic["message"].startswith("not checked: the URI")
    assert "holds a NUL character" in diagnostic["message"]
    for method in ("textDocument/hover", "textDocument/definition", "textDocument/completion"):
        with pytest.raises(ServerError) as raised:
            client.request(method, {"textDocument": {"uri": bad},
                                    "position": {"line": 0, "character": 0}}, timeout=10)
        assert raised.value.args[0]["code"] == INVALID_PARAMS
    with pytest.raises(ServerError):
        client.request("textDocument/hover", {"textDocument": {"uri": "file:///a\ud800.rapid"},
                                              "position": {"line": 0, "character": 0}})
    _serves(client, uri)


@pytest.mark.slow
def test_requests_after_shutdown_are_refused(tmp_path: Path) -> None:
    client = Client(cwd=tmp_path)
    try:
        client.initialize(tmp_path)
        assert client.request("shutdown") is None
        with pytest.raises(ServerError) as raised:
            client.request("textDocument/hover", {"textDocument": {"uri": "file:///x.rapid"},
                                                  "position": {"line": 0, "character": 0}})
        assert raised.value.args[0] == {"code": INVALID_REQUEST,
                                        "message": "the server is shutting down (after "
                                                   "`shutdown`)"}
        client.notify("exit")
        assert client.wait() == 0
    finally:
        if client.process.poll() is None:
            client.process.kill()
            client.process.wait()


# ------------------------------------------------------------------------------ documents

@pytest.mark.slow
def test_a_large_document_holds_up_no_request_about_another(tmp_path: Path) -> None:
    # Regression: documents were checked on the event loop, and a hover on a small document
    # waited 16 s for the check of a large one.
    client = Client(cwd=tmp_path)
    try:
        client.initialize(tmp_path)
        large = generate_strategy_file(15_000)   # about 9 s to check here
        big = client.open(tmp_path / "large.rapid", large)
        small = client.open(tmp_path / "small.rapid", SMALL)
        clock = time.perf_counter()
        assert client.diagnostics(small) == []
        _serves(client, small)
        waited = time.perf_counter() - clock
        assert waited < 2.5, waited
        published = client.wait_for("textDocument/publishDiagnostics", big, timeout=120)
        # and the large one is checked (its lint warnings come too)
        assert {d["severity"] for d in published["diagnostics"]} <= {2}
    finally:
        client.close()


# ------------------------------------------------------------------------- hostile frames

_SURROGATES = st.characters(min_codepoint=0xD800, max_codepoint=0xDFFF, categories=["Cs"])
_TEXT = st.text(st.one_of(st.characters(), _SURROGATES), max_size=12)
_JSON = st.recursive(st.none() | st.booleans() | st.integers() | st.floats() | _TEXT,
                     lambda inner: st.lists(inner, max_size=4)
                     | st.dictionaries(_TEXT, inner, max_size=4), max_leaves=12)
_NUMBERS = st.one_of(st.integers(), st.integers(-3, 40), st.floats(), _TEXT)
_POSITIONS = st.one_of(_JSON, st.fixed_dictionaries({"line": _NUMBERS, "character": _NUMBERS}))
_METHODS = st.sampled_from(["textDocument/hover", "textDocument/definition",
                            "textDocument/completion", "textDocument/formatting",
                            "no/such", "initialize"]) | _TEXT
_HEADERS = st.sampled_from(["right", "short", "negative", "huge", "word", "missing", "twice",
                            "lower-case"])
_BODIES = st.sampled_from(["message", "cut", "deep", "bytes"])
_keys = itertools.count()
EXAMPLES = 150


@pytest.mark.slow
@settings(max_examples=EXAMPLES, deadline=None,
          suppress_health_check=[HealthCheck.too_slow, HealthCheck.data_too_large])
@given(method=_METHODS, position=_POSITIONS, uri=st.sampled_from(["open", "closed", "nul"]),
       params=_JSON, header=_HEADERS, body=_BODIES, at=st.floats(0, 1),
       depth=st.integers(1, 3000))
def test_every_request_is_answered_and_the_server_goes_on(
        hostile: tuple[Client, str], method: str, position: Any, uri: str, params: Any,
        header: str, body: str, at: float, depth: int) -> None:
    client, open_uri = hostile
    key = f"h{next(_keys)}"
    named = {"open": open_uri, "closed": "file:///nowhere/x.rapid",
             "nul": "file:///x%00.rapid"}[uri]
    message: dict[str, Any] = {"jsonrpc": "2.0", "id": key, "method": method,
                               "params": {"textDocument": {"uri": named}, "position": position,
                                          "extra": params}}
    data = json.dumps(message).encode()
    if body == "cut":
        data = data[:max(int(len(data) * at), 1)]
    elif body == "deep":
        data = data.replace(b'"extra": ', b'"extra": ' + b"[" * depth, 1)[:-1] \
            + b"]" * depth + b"}"
    elif body == "bytes":
        cut = int(len(data) * at)
        data = data[:cut] + b"\xc3\x28\xff" + data[cut:]
    length = {"right": len(data), "short": max(len(data) - 3, 0)}.get(header)
    head = {"negative": b"Content-Length: -5\r\n", "huge": b"Content-Length: 1" + b"0" * 20
            + b"\r\n", "word": b"Content-Length: many\r\n", "missing": b"",
            "twice": b"Content-Length: 1\r\nContent-Length: 2\r\n",
            "lower-case": b"content-length: %d\r\n" % len(data)}.get(header)
    if length is not None:
        head = b"Content-Length: %d\r\n" % length
    assert head is not None
    client.send_bytes(head + b"\r\n" + data)
    hover = client.request("textDocument/hover", {"textDocument": {"uri": open_uri},
                                                  "position": {"line": 0, "character": 36}})
    assert "distance(a: Body" in hover["contents"]["value"], "the server stopped serving"
    if header in ("right", "lower-case"):
        # a whole frame: answered by its id; by null when the id cannot be read back; by what
        # it reads as the id when bytes that are not UTF-8 are in it
        answers = _answers(client)
        assert answers and all("result" in a or "error" in a for a in answers), answers
        if body in ("message", "deep"):
            assert [a["id"] for a in answers] == [key], answers
    client.unnamed.clear()
    client.responses.clear()


def _answers(client: Client) -> list[dict[str, Any]]:
    """The responses that came besides those the test asked for (waiting up to 10 s for one)."""
    deadline = time.monotonic() + 10
    with client.arrived:
        while not (client.responses or client.unnamed) and time.monotonic() < deadline:
            client.arrived.wait(0.2)
        found = [*client.responses.values(), *client.unnamed]
        client.responses.clear()
        client.unnamed.clear()
    return found
