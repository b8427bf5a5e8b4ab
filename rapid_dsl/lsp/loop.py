"""The language server's main loop, in place of pygls's reader: every request is answered.

A thread reads frames (frames.py); each body is read by `rapid_dsl.language.jsonrpc.read` (UTF-8,
JSON, at most MAX_NESTING deep, one JSON-RPC message), then made into pygls's types here rather than
inside pygls's reader, which answers nothing when that fails: a request whose params do not fit its
method (a negative or non-integer position, a missing field) gets an invalid-params error (-32602)
with its id. A request after `shutdown` gets an invalid-request error (pygls would drop it). What
remains goes to pygls's protocol as its own reader hands it over.
"""

from __future__ import annotations

import asyncio
import json
from concurrent.futures import ThreadPoolExecutor
from typing import TYPE_CHECKING, Any, BinaryIO

import cattrs
from cattrs.v import format_exception
from pygls.exceptions import JsonRpcException
from pygls.io_ import StdoutWriter

from rapid_dsl.language.jsonrpc import (
    INTERNAL_ERROR,
    INVALID_REQUEST,
    Invalid,
    error_response,
    read,
)
from rapid_dsl.lsp.frames import Frames

if TYPE_CHECKING:
    from rapid_dsl.lsp.server import RapidServer


def start(server: RapidServer, stdin: BinaryIO, stdout: BinaryIO) -> None:
    """Serve `stdin` until `exit` or its end; answers go to `stdout`."""
    server.protocol.set_writer(StdoutWriter(stdout))
    try:
        asyncio.run(_serve(server, Frames(stdin)))   # type: ignore[arg-type]
    except (BrokenPipeError, KeyboardInterrupt, SystemExit):   # SystemExit: pygls's `exit`
        pass
    finally:
        server.shutdown()


async def _serve(server: RapidServer, frames: Frames) -> None:
    loop = asyncio.get_running_loop()
    # not the default executor: asyncio.run would wait for a read that may never return
    reader = ThreadPoolExecutor(1, thread_name_prefix="rapidc-lsp-reader")
    try:
        while (frame := await loop.run_in_executor(reader, frames.next)) is not None:
            if isinstance(frame, Invalid):
                answer(server, frame.response())
            else:
                dispatch(server, frame)
    finally:
        reader.shutdown(wait=False)


def dispatch(server: RapidServer, frame: bytes) -> None:
    try:
        value = read(frame)
    except Invalid as invalid:
        answer(server, invalid.response())
        return
    request = "method" in value and "id" in value
    if server.shutdown_requested and value.get("method") != "exit":
        if request:
            answer(server, error_response(value["id"], INVALID_REQUEST,
                                          "the server is shutting down (after `shutdown`)"))
        return
    try:
        message = server.protocol.structure_message(value)
    except JsonRpcException as exc:
        problem = f"{exc.message}: {_details(exc)}"
        if request:
            answer(server, error_response(value["id"], exc.code, problem))
        else:
            server.log(f"ignored {value.get('method')!r}: {problem}")
        return
    try:
        server.protocol.handle_message(message)
    except Exception as exc:  # noqa: BLE001 - pygls answers its handlers' errors; a bug of its own
        server.bug(exc)       # must not stop the loop
        if request:
            answer(server, error_response(value["id"], INTERNAL_ERROR, "internal error"))


def answer(server: RapidServer, response: dict[str, Any]) -> None:
    """Write a response pygls did not make (as pygls writes its own)."""
    body = json.dumps(response)   # ASCII: its length in characters is its length in bytes
    data = f"Content-Length: {len(body)}\r\n\r\n{body}".encode()
    writer = server.protocol.writer
    assert writer is not None
    writer.write(data)


def _details(exc: JsonRpcException) -> str:
    """What did not fit, from the validation error behind pygls's exception."""
    cause = exc.__cause__
    if not isinstance(cause, cattrs.BaseValidationError):
        return str(cause)[:300]

    def shown(error: BaseException, kind: Any) -> str:
        if type(error) is ValueError and str(error):   # lsprotocol's range checks say the most
            return str(error)
        return format_exception(error, kind)
    details = cattrs.transform_error(cause, format_exception=shown)
    return "; ".join(details)[:500]
