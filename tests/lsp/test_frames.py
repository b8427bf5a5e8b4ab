"""In process: the frame reader (rapid_dsl/lsp/frames.py) and the message reader both servers use
(rapid_dsl/language/jsonrpc.py), on hostile bytes."""

from __future__ import annotations

import io
import json
from typing import Any

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from rapid_dsl.language.jsonrpc import MAX_NESTING, Invalid, read
from rapid_dsl.lsp.frames import Frames

GOOD = b'{"jsonrpc": "2.0", "id": 1, "method": "shutdown"}'


def _frames(data: bytes) -> list[bytes | Invalid]:
    frames = Frames(io.BufferedReader(io.BytesIO(data)))   # type: ignore[arg-type]
    out: list[bytes | Invalid] = []
    while (frame := frames.next()) is not None:
        out.append(frame)
    return out


def _frame(body: bytes) -> bytes:
    return b"Content-Length: %d\r\n\r\n" % len(body) + body


def test_headers_as_editors_write_them() -> None:
    assert _frames(_frame(GOOD) + b"content-length:%d\nContent-Type: x\n\n" % len(GOOD) + GOOD
                   ) == [GOOD, GOOD]
    assert _frames(b"\r\n" + _frame(b"")) == [b""]
    assert _frames(_frame(GOOD)[:-3]) == []       # the stream ended in the middle of a frame


_BAD_HEADERS = st.sampled_from([
    b"Content-Length: -1\r\n", b"Content-Length: 1e3\r\n", b"Content-Length: \r\n",
    b"Content-Length: " + b"9" * 5000 + b"\r\n", b"Content-Length: 67108865\r\n",
    b"Content-Type: text/plain\r\n", b"Content-Length: 3\r\nContent-Length: 4\r\n",
    b"X: " + b"y" * 9000 + b"\r\n", b"X: y\r\n" * 40])
_BODIES = st.binary(max_size=200).filter(lambda b: b"content-length" not in b.lower())


@pytest.mark.slow
@settings(max_examples=300)
@given(st.lists(st.tuples(_BAD_HEADERS, _BODIES), max_size=4))
def test_a_frame_after_frames_with_bad_headers_is_read(bad: list[tuple[bytes, bytes]]) -> None:
    data = b"".join(header + b"\r\n" + body for header, body in bad) + _frame(GOOD)
    frames = _frames(data)
    assert frames[-1] == GOOD
    assert all(isinstance(f, Invalid) for f in frames[:-1])
    assert (len(frames) > 1) == bool(bad)      # each run of bad frames is answered


_JSON = st.recursive(st.none() | st.booleans() | st.integers() | st.floats() | st.text(),
                     lambda inner: st.lists(inner, max_size=3)
                     | st.dictionaries(st.text(), inner, max_size=3), max_leaves=10)


@pytest.mark.slow
@settings(max_examples=300)
@given(st.binary(max_size=300) | _JSON.map(lambda v: json.dumps(v).encode()))
def test_any_bytes_are_a_message_or_invalid(data: bytes) -> None:
    try:
        message = read(data)
    except Invalid as invalid:
        assert invalid.response()["error"]["code"] in (-32700, -32600)
    else:
        assert isinstance(message, dict) and message["jsonrpc"] == "2.0"


@given(st.integers(-2**63, 2**63) | st.text(max_size=20), st.integers(1, 3000),
       st.booleans())
def test_the_id_of_a_refused_request_is_read_back(key: Any, depth: int, surrogate: bool) -> None:
    params = "[" * depth + "]" * depth
    text = ("\\ud800" if surrogate else "x")
    data = (f'{{"jsonrpc": "2.0", "id": {json.dumps(key)}, "method": "m", '
            f'"params": {{"a": "{text}", "b": {params}}}}}').encode()
    try:
        read(data, unicode_only=True)
    except Invalid as invalid:
        assert surrogate or depth + 2 > MAX_NESTING
        assert invalid.id == (None if isinstance(key, str) and any(
            0xD800 <= ord(c) <= 0xDFFF for c in key) else key)
    else:
        assert not surrogate and depth + 2 <= MAX_NESTING
