"""Latency of `rapidc lsp` on a 200-line strategy file (target: diagnostics under 100 ms).

Starts the server as a process (pygls' own client, over stdio) and measures, each the median of
--runs: the server's start-up to its answer to `initialize`; didOpen -> publishDiagnostics for a
new 200-line file (`rapidc bench check`'s generated one, which checks clean); didChange (one
character, full text) -> publishDiagnostics, which includes the server's 20 ms debounce; the
same for a change that makes an error (E0302); and a hover, which builds the typed model once
per version.

Usage: python -m rapid_dsl.bench.lsp_latency [--runs N] [--json]
"""

from __future__ import annotations

import argparse
import asyncio
import json
import statistics
import sys
import tempfile
import time
from pathlib import Path

from lsprotocol import types
from pygls.lsp.client import LanguageClient

from rapid_dsl.bench.check import generate_strategy_file

TARGET_MS = 100.0


def _errors(diagnostics: list[types.Diagnostic]) -> int:
    """Errors only: the file has lint warnings, which the server reports by default."""
    return sum(d.severity == types.DiagnosticSeverity.Error for d in diagnostics)


async def measure(runs: int) -> dict[str, float | int]:
    text = generate_strategy_file(200)
    published: asyncio.Queue[types.PublishDiagnosticsParams] = asyncio.Queue()
    client = LanguageClient("bench-lsp", "1")

    @client.feature(types.TEXT_DOCUMENT_PUBLISH_DIAGNOSTICS)
    def diagnostics(params: types.PublishDiagnosticsParams) -> None:
        published.put_nowait(params)

    async def until(uri: str, version: int) -> list[types.Diagnostic]:
        while True:
            params = await published.get()
            if params.uri == uri and params.version == version:
                return params.diagnostics

    with tempfile.TemporaryDirectory(prefix="rapidc-bench-lsp-") as folder:
        start = time.perf_counter()
        await client.start_io(sys.executable, "-m", "rapid_dsl", "lsp")
        await client.initialize_async(types.InitializeParams(
            capabilities=types.ClientCapabilities(), root_uri=Path(folder).as_uri()))
        startup_ms = (time.perf_counter() - start) * 1000
        client.initialized(types.InitializedParams())
        opened, changed, broken, hovered = [], [], [], []
        errors = 0
        for run in range(runs):
            path = Path(folder, f"strategy_{run}.rapid")
            path.write_text(text, encoding="utf-8")
            uri = path.as_uri()
            start = time.perf_counter()
            client.text_document_did_open(types.DidOpenTextDocumentParams(
                types.TextDocumentItem(uri, "rapid", 1, text)))
            errors += _errors(await until(uri, 1))
            opened.append((time.perf_counter() - start) * 1000)
            for version, new, times in ((2, text + "\n", changed),
                                        (3, text.replace("< margin", "< 1", 1), broken)):
                start = time.perf_counter()
                client.text_document_did_change(types.DidChangeTextDocumentParams(
                    types.VersionedTextDocumentIdentifier(version, uri),
                    [types.TextDocumentContentChangeWholeDocument(new)]))
                found = _errors(await until(uri, version))
                times.append((time.perf_counter() - start) * 1000)
                errors += found if version == 2 else found != 1
            line = text.count("\n", 0, text.index("tilt(box) > 60deg"))
            start = time.perf_counter()
            await client.text_document_hover_async(types.HoverParams(
                types.TextDocumentIdentifier(uri), types.Position(line, 14)))
            hovered.append((time.perf_counter() - start) * 1000)
        await client.shutdown_async(None)
        client.exit(None)
        await client.stop()
    return {"lines": text.count("\n"), "runs": runs, "startup_ms": startup_ms,
            "open_ms": statistics.median(opened), "first_open_ms": opened[0],
            "change_ms": statistics.median(changed), "error_ms": statistics.median(broken),
            "hover_ms": statistics.median(hovered), "errors": errors}


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--runs", type=int, default=10)
    parser.add_argument("--json", action="store_true")
    args = parser.parse_args()
    numbers = asyncio.run(measure(max(args.runs, 1)))
    if args.json:
        print(json.dumps(numbers, indent=2))
    else:
        def verdict(ms: float) -> str:
            return f"(target < {TARGET_MS:.0f} ms: {'ok' if ms < TARGET_MS else 'MISSED'})"

        print(f"rapidc lsp, {numbers['lines']}-line strategy file, median of {numbers['runs']}")
        print(f"  start-up to the initialize answer: {numbers['startup_ms']:7.1f} ms")
        print(f"  didOpen -> diagnostics (first):    {numbers['first_open_ms']:7.1f} ms  "
              + verdict(float(numbers["first_open_ms"])))
        print(f"  didOpen -> diagnostics:            {numbers['open_ms']:7.1f} ms  "
              + verdict(float(numbers["open_ms"])))
        print(f"  didChange -> diagnostics:          {numbers['change_ms']:7.1f} ms  "
              + verdict(float(numbers["change_ms"])) + "  [20 ms of it the debounce]")
        print(f"  didChange to an error -> it:       {numbers['error_ms']:7.1f} ms  "
              + verdict(float(numbers["error_ms"])))
        print(f"  hover (builds the model):          {numbers['hover_ms']:7.1f} ms")
    if numbers["errors"]:
        print(f"bench_lsp: {numbers['errors']} checks found other errors than expected (none "
              "in the clean file, one after the breaking change)", file=sys.stderr)
        return 1
    return 0


if __name__ == "__main__":
    sys.exit(main())
