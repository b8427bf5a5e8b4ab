"""`rapidc mcp`'s check round trip: a tools/call of `check` on a ~200-line strategy file, timed by
the MCP SDK's own stdio client from the request to the result, after the server has started and
answered once, the file edited before each call (target < 100 ms). Also: the time from starting
the server to its first answer.

Usage: python -m rapid_dsl.bench.mcp_latency [--runs N] [--json]
"""

from __future__ import annotations

import argparse
import json
import statistics
import sys
import tempfile
import time
from pathlib import Path

import anyio
from mcp import ClientSession, StdioServerParameters, stdio_client

from rapid_dsl.bench.check import generate_strategy_file


async def measure(folder: Path, runs: int) -> dict[str, float]:
    program = folder / "strategy.rapid"
    program.write_text(generate_strategy_file(200), encoding="utf-8")
    lines = len(program.read_text(encoding="utf-8").splitlines())
    params = StdioServerParameters(command=sys.executable,
                                   args=["-m", "rapid_dsl", "mcp", "--root", str(folder)],
                                   cwd=str(folder))
    started = time.perf_counter()
    async with stdio_client(params) as (read, write), ClientSession(read, write) as session:
        await session.initialize()
        ready = time.perf_counter()
        first = await session.call_tool("check", {"paths": [program.name]})
        answered = time.perf_counter()
        assert first.structured_content is not None
        assert first.structured_content["exit_status"] == 0, first.structured_content
        text = program.read_text(encoding="utf-8")
        times = []
        for i in range(runs):
            # an agent checks the file it just edited: new text every time (no parse cache)
            program.write_text(f"{text}# edit {i}\n", encoding="utf-8")
            clock = time.perf_counter()
            result = await session.call_tool("check", {"paths": [program.name]})
            times.append(time.perf_counter() - clock)
            assert result.structured_content is not None
            assert result.structured_content["exit_status"] == 0
    return {"lines": lines, "start_to_initialized_s": ready - started,
            "first_check_ms": 1000 * (answered - ready),
            "check_round_trip_median_ms": 1000 * statistics.median(times),
            "check_round_trip_min_ms": 1000 * min(times),
            "check_round_trip_max_ms": 1000 * max(times), "runs": runs}


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--runs", type=int, default=30)
    parser.add_argument("--json", action="store_true")
    options = parser.parse_args()
    with tempfile.TemporaryDirectory(prefix="bench-mcp-") as folder:
        numbers = anyio.run(measure, Path(folder), options.runs)
    if options.json:
        print(json.dumps(numbers, indent=2))
    else:
        print(f"server start to initialized: {numbers['start_to_initialized_s']:.2f} s")
        print(f"first check ({numbers['lines']} lines): {numbers['first_check_ms']:.0f} ms")
        print(f"check round trip, median of {numbers['runs']}: "
              f"{numbers['check_round_trip_median_ms']:.1f} ms (min "
              f"{numbers['check_round_trip_min_ms']:.1f}, max "
              f"{numbers['check_round_trip_max_ms']:.1f}; target < 100 ms)")
    return 0


if __name__ == "__main__":
    sys.exit(main())
