"""`rapidc mcp` driven over its stdin and stdout with raw lines, for what the SDK's client cannot
send: lines that are not JSON, lone surrogates, deep nesting, oversized lines.

A reader thread files each line the server writes: answers by id (null ids in arrival order),
notifications in arrival order.
"""

from __future__ import annotations

import json
import subprocess
import sys
import threading
import time
from pathlib import Path
from typing import Any

TIMEOUT = 30.0   # seconds; generous for a loaded 2-core machine


class Wire:
    def __init__(self, root: Path, *options: str) -> None:
        self.process = subprocess.Popen(
            [sys.executable, "-m", "rapid_dsl", "mcp", "--root", str(root), *options],
            stdin=subprocess.PIPE, stdout=subprocess.PIPE, stderr=subprocess.PIPE, cwd=root)
        self.answers: dict[Any, dict[str, Any]] = {}
        self.unnamed: list[dict[str, Any]] = []     # answers with a null id
        self.notifications: list[dict[str, Any]] = []
        self.arrived = threading.Condition()
        threading.Thread(target=self._read, daemon=True).start()

    def _read(self) -> None:
        assert self.process.stdout is not None
        for line in self.process.stdout:
            message = json.loads(line)
            with self.arrived:
                if "method" in message:
                    self.notifications.append(message)
                elif message.get("id") is None:
                    self.unnamed.append(message)
                else:
                    self.answers[message["id"]] = message
                self.arrived.notify_all()

    def send_bytes(self, data: bytes) -> None:
        assert self.process.stdin is not None
        self.process.stdin.write(data)
        self.process.stdin.flush()

    def send(self, message: dict[str, Any]) -> None:
        self.send_bytes(json.dumps(message).encode() + b"\n")

    def wait(self, found: Any, timeout: float = TIMEOUT) -> Any:
        """The first true value of `found()`, evaluated as lines arrive."""
        deadline = time.monotonic() + timeout
        with self.arrived:
            while not (value := found()):
                left = deadline - time.monotonic()
                if left <= 0 or self.process.poll() is not None:
                    raise TimeoutError(f"no answer in {timeout} s; server: {self.stderr()}")
                self.arrived.wait(min(left, 0.5))
            return value

    def answer(self, key: Any, timeout: float = TIMEOUT) -> dict[str, Any]:
        return self.wait(lambda: self.answers.pop(key, None), timeout)   # type: ignore[no-any-return]

    def unnamed_answer(self, timeout: float = TIMEOUT) -> dict[str, Any]:
        return self.wait(lambda: self.unnamed.pop(0) if self.unnamed else None,   # type: ignore
                         timeout)

    def request(self, key: Any, method: str, params: Any = None) -> dict[str, Any]:
        self.send({"jsonrpc": "2.0", "id": key, "method": method,
                   **({} if params is None else {"params": params})})
        return self.answer(key)

    def initialize(self) -> None:
        answer = self.request("init", "initialize", {
            "protocolVersion": "2025-06-18", "capabilities": {},
            "clientInfo": {"name": "wire", "version": "0"}})
        assert "result" in answer, answer
        self.send({"jsonrpc": "2.0", "method": "notifications/initialized"})

    def close(self) -> int:
        if self.process.stdin is not None and not self.process.stdin.closed:
            self.process.stdin.close()
        try:
            return self.process.wait(TIMEOUT)
        finally:
            if self.process.poll() is None:
                self.process.kill()
                self.process.wait()

    def stderr(self) -> str:
        if self.process.poll() is None or self.process.stderr is None:
            return "(still running)"
        return self.process.stderr.read().decode("utf-8", "replace")[-2000:]
