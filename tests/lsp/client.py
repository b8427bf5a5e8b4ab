"""A small LSP client for the tests: starts `rapidc lsp` as a process and speaks JSON-RPC with it
over its standard input and output, with plain JSON (what goes over the wire, not pygls' types).

A reader thread files each message from the server: responses by id (those with a null id in
arrival order), notifications in arrival order, requests from the server answered with null.
`send_bytes` writes anything at all, for what a well-behaved client would never send.
"""

from __future__ import annotations

import json
import os
import queue
import subprocess
import sys
import threading
import time
from pathlib import Path
from typing import Any

TIMEOUT = 20.0   # seconds; generous for a loaded 2-core machine


class ServerError(Exception):
    pass


class Client:
    def __init__(self, *args: str, cwd: Path | None = None) -> None:
        env = {**os.environ, "PYTHONUNBUFFERED": "1"}
        self.process = subprocess.Popen(
            [sys.executable, "-m", "rapid_dsl", "lsp", *args], stdin=subprocess.PIPE,
            stdout=subprocess.PIPE, stderr=subprocess.PIPE, cwd=cwd, env=env)
        self.responses: dict[Any, dict[str, Any]] = {}
        self.unnamed: list[dict[str, Any]] = []     # responses with a null id
        self.notifications: queue.Queue[dict[str, Any]] = queue.Queue()
        self.seen: list[dict[str, Any]] = []     # notifications already taken from the queue
        self.arrived = threading.Condition()
        self.next_id = 0
        self.reader = threading.Thread(target=self._read, daemon=True)
        self.reader.start()

    # wire -------------------------------------------------------------------------------------
    def _send(self, message: dict[str, Any]) -> None:
        body = json.dumps({"jsonrpc": "2.0", **message}).encode("utf-8")
        self.send_bytes(b"Content-Length: %d\r\n\r\n" % len(body) + body)

    def send_bytes(self, data: bytes) -> None:
        assert self.process.stdin is not None
        self.process.stdin.write(data)
        self.process.stdin.flush()

    def _read(self) -> None:
        stream = self.process.stdout
        assert stream is not None
        while True:
            length = None
            while True:
                line = stream.readline()
                if not line:
                    return
                if line in (b"\r\n", b"\n"):
                    break
                name, _, value = line.decode("ascii").partition(":")
                if name.lower() == "content-length":
                    length = int(value)
            assert length is not None, "a message without Content-Length"
            message = json.loads(stream.read(length))
            if "id" in message and "method" in message:     # a request from the server
                self._send({"id": message["id"], "result": None})
            elif "id" in message:
                with self.arrived:
                    if message["id"] is None:
                        self.unnamed.append(message)
                    else:
                        self.responses[message["id"]] = message
                    self.arrived.notify_all()
            else:
                self.notifications.put(message)

    # requests and notifications ---------------------------------------------------------------
    def request(self, method: str, params: Any = None, timeout: float = TIMEOUT) -> Any:
        self.next_id += 1
        key = self.next_id
        self._send({"id": key, "method": method, "params": params})
        response = self.response(key, timeout)
        if "error" in response:
            raise ServerError(response["error"])
        return response.get("result")

    def response(self, key: Any, timeout: float = TIMEOUT) -> dict[str, Any]:
        """The response with id `key` (None: the next response with a null id), as sent."""
        def arrived() -> bool:
            return key in self.responses if key is not None else bool(self.unnamed)

        deadline = time.monotonic() + timeout
        with self.arrived:
            while not arrived():
                left = deadline - time.monotonic()
                if left <= 0:
                    raise TimeoutError(f"no answer to {key} in {timeout} s: {self.stderr()}")
                self.arrived.wait(left)
            return self.responses.pop(key) if key is not None else self.unnamed.pop(0)

    def notify(self, method: str, params: Any = None) -> None:
        self._send({"method": method, "params": params})

    def wait_for(self, method: str, uri: str | None = None, version: int | None = None,
                 timeout: float = TIMEOUT) -> dict[str, Any]:
        """The params of the next notification `method` (for `uri` and `version` if given)."""
        deadline = time.monotonic() + timeout
        while True:
            left = deadline - time.monotonic()
            if left <= 0:
                raise TimeoutError(f"no {method} for {uri} in {timeout} s: {self.stderr()}")
            try:
                message = self.notifications.get(timeout=left)
            except queue.Empty:
                continue
            self.seen.append(message)
            params = message.get("params") or {}
            if message.get("method") == method and (uri is None or params.get("uri") == uri) \
                    and (version is None or params.get("version") == version):
                return params

    def diagnostics(self, uri: str, version: int | None = None) -> list[dict[str, Any]]:
        return self.wait_for("textDocument/publishDiagnostics", uri, version)["diagnostics"]

    # session ----------------------------------------------------------------------------------
    def initialize(self, root: Path, capabilities: dict[str, Any] | None = None,
                   options: dict[str, Any] | None = None) -> dict[str, Any]:
        params: dict[str, Any] = {"processId": os.getpid(), "rootUri": root.as_uri(),
                                  "capabilities": capabilities or {}}
        if options is not None:
            params["initializationOptions"] = options
        result = self.request("initialize", params)
        self.notify("initialized", {})
        return result

    def open(self, path: Path, text: str | None = None, version: int = 1,
             language: str = "rapid") -> str:
        uri = path.as_uri()
        self.notify("textDocument/didOpen", {"textDocument": {
            "uri": uri, "languageId": language, "version": version,
            "text": path.read_text(encoding="utf-8") if text is None else text}})
        return uri

    def close(self, timeout: float = TIMEOUT) -> int:
        """shutdown, exit, and the server's exit status."""
        if self.process.poll() is None:
            self.request("shutdown")
            self.notify("exit")
        return self.wait(timeout)

    def wait(self, timeout: float = TIMEOUT) -> int:
        try:
            return self.process.wait(timeout)
        finally:
            if self.process.poll() is None:
                self.process.kill()
                self.process.wait()

    def stderr(self) -> str:
        if self.process.poll() is None or self.process.stderr is None:
            return "(server still running)"
        return self.process.stderr.read().decode("utf-8", "replace")[-2000:]


def position(text: str, needle: str, after: int = 0) -> dict[str, int]:
    """The LSP position (UTF-16 columns) of `needle` in `text` (plus `after` code points)."""
    index = text.index(needle) + after
    line = text.count("\n", 0, index)
    start = text.rfind("\n", 0, index) + 1
    return {"line": line, "character": len(text[start:index].encode("utf-16-le")) // 2}
