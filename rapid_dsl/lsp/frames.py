"""The LSP base protocol's frames, read from the editor's byte stream: header lines (`Name: value`),
a blank line, then `Content-Length` bytes of JSON.

pygls reads frames itself, but stops serving on a header it cannot use: a Content-Length that is
not a count or too large for memory raises, and after one that is negative or missing the body is
read as headers and no later request is answered. Here a frame whose header is unusable (no or
two Content-Length, a value that is not a count or over MAX_FRAME_BYTES, a header line over
MAX_HEADER_LINE bytes or more than MAX_HEADER_LINES of them) comes back as `Invalid`, to be
answered with an error (its id cannot be known: null), and reading goes on at the next
`Content-Length` header: after the frame's header; or, for a "header" with no Content-Length line
(the rest of a body whose length was too short, read on as a header), after its first byte, so
that a header among its lines is found. (A length longer than the body sent makes the frame wait
for the rest, as it must.)
"""

from __future__ import annotations

import re
from typing import Protocol

from rapid_dsl.language.jsonrpc import INVALID_REQUEST, MAX_FRAME_BYTES, PARSE_ERROR, Invalid

MAX_HEADER_LINE = 8 * 1024
MAX_HEADER_LINES = 32
_CHUNK = 64 * 1024
_NEXT_HEADER = re.compile(rb"content-length", re.IGNORECASE)
_COUNT = re.compile(rb"\s*(\d+)\s*")


class Readable(Protocol):
    def read1(self, size: int = ..., /) -> bytes: ...


class Frames:
    """The frames of a stream that `read1` reads (what is there, at most `size` bytes)."""

    def __init__(self, stream: Readable) -> None:
        self._stream = stream
        self._buffer = bytearray()
        self._ended = False
        self._lost = False       # the last frame's header was unusable: find the next one

    def next(self) -> bytes | Invalid | None:
        """The next frame's body; Invalid for a frame with an unusable header; None at the end
        of the stream (also in the middle of a frame)."""
        if self._lost:   # not before the last frame was answered: the next may not be sent yet
            self._skip_to_next_header()
            self._lost = False
        length: int | None = None
        problem: Invalid | None = None
        count = 0
        header = bytearray()
        named = False            # a Content-Length line was read
        while True:
            line = self._line()
            if line is None:
                return None
            if not line.strip() and count == 0:
                continue            # blank lines between frames
            header += line
            if not line.strip():
                break
            count += 1
            if len(line) > MAX_HEADER_LINE or count > MAX_HEADER_LINES:
                problem = _invalid(f"a frame's header is at most {MAX_HEADER_LINES} lines of "
                                   f"{MAX_HEADER_LINE // 1024} KiB")
                break
            name, colon, value = line.partition(b":")
            if not colon or name.strip().lower() != b"content-length":
                continue            # Content-Type and headers to come are not read
            named = True
            match = _COUNT.fullmatch(value)
            if length is not None:
                problem = _invalid("a frame has two Content-Length headers")
            elif match is None:
                shown = value.strip()[:40].decode("ascii", "replace")
                problem = _invalid(f"Content-Length `{shown}` is not a count of bytes")
            else:   # (a count of more digits than any file size is too large, not read)
                digits = match.group(1)
                length = int(digits) if len(digits) <= 20 else MAX_FRAME_BYTES + 1
        if problem is None and length is None:
            problem = _invalid("a frame has no Content-Length header")
        if problem is None and length is not None and length > MAX_FRAME_BYTES:
            problem = Invalid(INVALID_REQUEST,
                              f"a message is at most {MAX_FRAME_BYTES // 2**20} MiB")
        if problem is not None:
            if not named:
                self._buffer[:0] = header[1:]
            self._lost = True
            return problem
        assert length is not None
        return self._exactly(length)

    def _line(self) -> bytes | None:
        """The next line with its end, at most MAX_HEADER_LINE + 1 bytes (a longer one is cut
        there); None at the end of the stream."""
        while True:
            end = self._buffer.find(b"\n", 0, MAX_HEADER_LINE + 1)
            if end >= 0 or len(self._buffer) > MAX_HEADER_LINE:
                size = end + 1 if end >= 0 else MAX_HEADER_LINE + 1
                line = bytes(self._buffer[:size])
                del self._buffer[:size]
                return line
            if not self._fill():
                if not self._buffer:
                    return None
                line = bytes(self._buffer)
                self._buffer.clear()
                return line

    def _exactly(self, size: int) -> bytes | None:
        while len(self._buffer) < size:
            if not self._fill():
                return None
        body = bytes(self._buffer[:size])
        del self._buffer[:size]
        return body

    def _skip_to_next_header(self) -> None:
        """Drop bytes up to the next `Content-Length` (any case), or to the end of the stream."""
        keep = len(b"content-length") - 1    # the start of a name cut by a read
        while True:
            found = _NEXT_HEADER.search(self._buffer)
            if found is not None:
                del self._buffer[:found.start()]
                return
            del self._buffer[:max(len(self._buffer) - keep, 0)]
            if not self._fill():
                self._buffer.clear()
                return

    def _fill(self) -> bool:
        if self._ended:
            return False
        data = self._stream.read1(_CHUNK)
        if not data:
            self._ended = True
            return False
        self._buffer += data
        return True


def _invalid(message: str) -> Invalid:
    return Invalid(PARSE_ERROR, message)
