"""The MCP server's stdio transport: one JSON-RPC message per line, each answered.

The SDK's own stdio transport drops a line its validator refuses (not JSON, a lone surrogate, JSON
nested past its parser's limit), and the client then waits forever for the answer. Here each line
is read by `rapid_dsl.language.jsonrpc.read` and then the SDK's validator: a line either reaches the
server as a message, or is answered at once with a JSON-RPC error (-32700 or -32600) carrying the
request's id when it can be read. A line is at most MAX_FRAME_BYTES; a longer one is read to its
end, dropped and answered the same way. Blank lines are skipped.

As in the SDK's transport, the protocol gets private copies of file descriptors 0 and 1, and
while it runs those point at the null device and at stderr: a command run by a tool call reads
nothing of the protocol and cannot print into it.
"""

from __future__ import annotations

import os
import sys
from collections.abc import AsyncIterator, Callable
from contextlib import asynccontextmanager, suppress
from typing import Any, BinaryIO

import anyio
import mcp_types as types
from anyio.streams.memory import MemoryObjectReceiveStream, MemoryObjectSendStream
from mcp.shared.message import SessionMessage
from pydantic import ValidationError

from rapid_dsl.language.jsonrpc import (
    INTERNAL_ERROR,
    INVALID_REQUEST,
    MAX_FRAME_BYTES,
    Invalid,
    read,
    recover_id,
)

Incoming = MemoryObjectReceiveStream[SessionMessage | Exception]
Outgoing = MemoryObjectSendStream[SessionMessage]
_CHUNK = 1024 * 1024


@asynccontextmanager
async def stdio() -> AsyncIterator[tuple[Incoming, Outgoing]]:
    """The server's read and write streams over this process's stdin and stdout."""
    wire_in, restore_in = _claim(0, "rb", lambda: os.open(os.devnull, os.O_RDONLY))
    wire_out, restore_out = _claim(1, "wb", lambda: os.dup(2))
    to_server, incoming = anyio.create_memory_object_stream[SessionMessage | Exception](0)
    outgoing, to_client = anyio.create_memory_object_stream[SessionMessage](0)
    try:
        async with anyio.create_task_group() as group:
            group.start_soon(_read, wire_in, to_server, outgoing.clone())
            group.start_soon(_write, wire_out, to_client)
            yield incoming, outgoing
    finally:
        restore_out()
        restore_in()


async def _read(wire: BinaryIO, to_server: MemoryObjectSendStream[SessionMessage | Exception],
                answers: Outgoing) -> None:
    async with to_server, answers:
        while True:
            line = await anyio.to_thread.run_sync(_line, wire, abandon_on_cancel=True)
            if line is None:
                return
            if not line.strip():
                continue
            try:
                message = message_of(line)
            except Invalid as invalid:
                await answers.send(SessionMessage(types.JSONRPCError(
                    jsonrpc="2.0", id=invalid.id,
                    error=types.ErrorData(code=invalid.code, message=invalid.message))))
                continue
            await to_server.send(SessionMessage(message))


def message_of(line: bytes) -> types.JSONRPCMessage:
    """The message of one line, as the SDK reads it; Invalid if the line cannot be one."""
    if len(line) > MAX_FRAME_BYTES:
        head = line[:4096].decode("utf-8", "replace")
        raise Invalid(INVALID_REQUEST, f"a message is at most {MAX_FRAME_BYTES // 2**20} MiB",
                      recover_id(head, unicode_only=True))
    value = read(line, unicode_only=True)
    try:
        message: types.JSONRPCMessage = types.jsonrpc_message_adapter.validate_python(
            value, by_name=False)
    except ValidationError as exc:
        first = exc.errors()[0]
        where = ".".join(str(part) for part in first["loc"][1:]) or "the message"
        raise Invalid(INVALID_REQUEST, f"not a JSON-RPC message: {where}: {first['msg']}",
                      value.get("id")) from None
    return message


def _line(wire: BinaryIO) -> bytes | None:
    """The next line (without its end), None at the end of input. A line over the limit comes
    back cut just past the limit (message_of refuses it), the rest of it read and dropped."""
    line = wire.readline(MAX_FRAME_BYTES + 1)
    if not line:
        return None
    if line.endswith(b"\n"):
        return line.rstrip(b"\r\n")
    if len(line) > MAX_FRAME_BYTES:
        while (rest := wire.readline(_CHUNK)) and not rest.endswith(b"\n"):
            pass
    return line


async def _write(wire: BinaryIO, to_client: MemoryObjectReceiveStream[SessionMessage]) -> None:
    async with to_client:
        async for item in to_client:
            data = _encoded(item.message)
            if data is not None:
                await anyio.to_thread.run_sync(_send, wire, data)


def _encoded(message: types.JSONRPCMessage) -> bytes | None:
    """The message as a line; a response that cannot be written as JSON (text that is not
    Unicode) becomes an internal error of its request, a notification is dropped."""
    try:
        return message.model_dump_json(by_alias=True, exclude_unset=True).encode() + b"\n"
    except ValueError as exc:
        print(f"rapidc mcp: a message could not be written as JSON: {exc}", file=sys.stderr)
        request = getattr(message, "id", None)
        if isinstance(message, types.JSONRPCNotification | types.JSONRPCRequest):
            return None
        answer = types.JSONRPCError(jsonrpc="2.0", id=request, error=types.ErrorData(
            code=INTERNAL_ERROR, message="the answer could not be written as JSON"))
        return answer.model_dump_json(by_alias=True, exclude_unset=True).encode() + b"\n"


def _send(wire: BinaryIO, data: bytes) -> None:
    wire.write(data)
    wire.flush()


def _claim(fd: int, mode: str, diversion: Callable[[], int]) -> tuple[Any, Callable[[], None]]:
    """A private copy of `fd` for the protocol, `fd` itself pointed at `diversion()`; and what
    points it back."""
    private = os.dup(fd)   # not inherited by child processes
    spare = diversion()
    os.dup2(spare, fd)
    os.close(spare)

    def restore() -> None:
        with suppress(OSError):
            os.dup2(private, fd)
            os.close(private)
    # buffered, but never closing the descriptor under a thread still blocked on it
    return os.fdopen(private, mode, closefd=False), restore
