"""What a command printed -> the tool call's result.

With `--format json` a command prints its diagnostics as one JSON array (on stdout for check and
lint, on stderr for the commands that print something else there), its JSON document on stdout
(bind, verify, variants) and its messages on stderr. The result sorts these out, in every tool
alike: `diagnostics`, `result`, `output` (text the command prints), `messages` (the rest of
stderr, progress lines left out: those went out as progress notifications while it ran).
"""

from __future__ import annotations

import json
import re
from typing import Any

from rapid_dsl.mcp.arguments import Call
from rapid_dsl.mcp.capture import Outcome

# The lines run, verify and variants print as they go when stderr is not a terminal
# (commands/run_report.py _plain_line, commands/verify_display.py, commands/variants.py).
_PROGRESS = re.compile(r"binding: |phase [A-Za-z_][A-Za-z0-9_]*(: | \()|verify: |variants: \d")


def is_progress(line: str) -> bool:
    return _PROGRESS.match(line) is not None


def is_error(status: int) -> bool:
    """Bad input, an internal error or an interruption; 1 (program errors, a failed run) is a
    result the call was made to find out."""
    return status >= 2


def envelope(call: Call, outcome: Outcome) -> dict[str, Any]:
    diagnostics, rest = split_diagnostics(outcome.stderr)
    result: Any = None
    output: str | None = None
    stdout = outcome.stdout
    if call.spec.stdout == "diagnostics":
        printed = _json(stdout)
        if isinstance(printed, list):
            diagnostics = printed + diagnostics
        elif stdout.strip():
            output = stdout
    elif call.spec.stdout == "json":
        result = _json(stdout)
        if result is None and stdout.strip():
            output = stdout
    elif stdout:
        output = stdout
    if call.result_file is not None:
        result = call.result()
    messages = [line for line in rest.splitlines() if line.strip() and not is_progress(line)]
    return call.unmask({"tool": call.spec.name, "exit_status": outcome.status,
                        "diagnostics": diagnostics, "result": result, "output": output,
                        "messages": messages})


def problem(tool: str, message: str, status: int = 2) -> dict[str, Any]:
    """The result of a call that could not start (bad arguments: exit status 2)."""
    return {"tool": tool, "exit_status": status, "diagnostics": [], "result": None,
            "output": None, "messages": [f"rapidc: error: {message}"]}


def split_diagnostics(stderr: str) -> tuple[list[dict[str, Any]], str]:
    """The JSON diagnostic arrays printed on stderr, and the other text."""
    decoder = json.JSONDecoder()
    found: list[dict[str, Any]] = []
    kept: list[str] = []
    at = 0
    while at < len(stderr):
        if stderr.startswith("[", at):
            try:
                value, end = decoder.raw_decode(stderr, at)
            except ValueError:
                value = None
            if isinstance(value, list) and all(isinstance(d, dict) and "code" in d
                                               for d in value):
                found += value
                at = end
                continue
        line_end = stderr.find("\n", at)
        line_end = len(stderr) if line_end < 0 else line_end + 1
        kept.append(stderr[at:line_end])
        at = line_end
    return found, "".join(kept)


def _json(text: str) -> Any:
    try:
        return json.loads(text) if text.strip() else None
    except ValueError:
        return None
