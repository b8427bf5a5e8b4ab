"""What `rapidc mcp` runs at once: quick commands side by side (a long or cancelled one holds up
no other), worker processes up to `--workers` with later calls queued and told so, and a call's
`jobs` lowered to that (docs/security.md, "Limits")."""

from __future__ import annotations

import time
from pathlib import Path

import anyio
import pytest
from conftest import PUSH_BOX, PUSH_SCENE, Progress, Server, make_project, serving
from mcp import ClientSession

from rapid_dsl.bench.check import generate_strategy_file

TINY = {"samples": 8, "iterations": 1}


def _descendants(pid: int) -> set[int]:
    """Every process below `pid` (Linux /proc), multiprocessing's resource tracker left out."""
    children: dict[int, list[int]] = {}
    for entry in Path("/proc").iterdir():
        if not entry.name.isdigit():
            continue
        try:
            status = (entry / "status").read_text()
            command = (entry / "cmdline").read_text(errors="replace")
        except OSError:
            continue
        if "resource_tracker" in command:
            continue
        parent = next(int(line.split()[1]) for line in status.splitlines()
                      if line.startswith("PPid:"))
        children.setdefault(parent, []).append(int(entry.name))
    found: set[int] = set()
    todo = [pid]
    while todo:
        for child in children.get(todo.pop(), []):
            found.add(child)
            todo.append(child)
    return found


def _server_pid(server: Server) -> int:
    [worker] = server.workers() or [None]   # a worker is a child of the server
    return int(Path(f"/proc/{worker}/status").read_text().split("PPid:")[1].split()[0])


@pytest.mark.slow
def test_a_long_or_cancelled_check_holds_up_no_other_call(tmp_path: Path) -> None:
    # Regression: quick commands ran one at a time, and a cancelled check held the lock until
    # its command returned (explain waited 12 s behind it).
    root = make_project(tmp_path)
    for name in ("long", "other"):     # two texts: the parser's cache would make a second quick
        text = generate_strategy_file(15_000) + f"# {name}\n"
        (root / f"{name}.rapid").write_text(text, encoding="utf-8")

    async def scenario(session: ClientSession) -> tuple[float, float]:
        async def explain() -> float:
            clock = time.perf_counter()
            result = await session.call_tool("explain", {"code": "E0101"})
            assert result.structured_content is not None
            assert result.structured_content["exit_status"] == 0
            return time.perf_counter() - clock

        async def check(name: str) -> None:
            await session.call_tool("check", {"paths": [f"{name}.rapid"]})

        async with anyio.create_task_group() as group:   # a check the client cancels
            group.start_soon(check, "long")
            await anyio.sleep(0.5)
            group.cancel_scope.cancel()
        after = await explain()
        async with anyio.create_task_group() as group:   # a check that runs on
            group.start_soon(check, "other")
            await anyio.sleep(1.0)
            beside = await explain()
            group.cancel_scope.cancel()
        return after, beside

    with serving(root) as server:
        after, beside = server.run(scenario)
        assert after < 2.5 and beside < 2.5, (after, beside)   # each check takes about 9 s
        assert "Traceback" not in server.stderr()


@pytest.mark.slow
def test_long_calls_wait_for_a_worker_process_and_say_so(tmp_path: Path) -> None:
    root = make_project(tmp_path)
    with serving(root, "--workers", "1", "--allow-path", str(PUSH_SCENE.parent)) as server:
        busiest = 0
        progress = [Progress() for _ in range(3)]
        bodies: list[dict[str, object]] = []

        async def scenario(session: ClientSession) -> None:
            nonlocal busiest

            async def variants(index: int) -> None:
                await anyio.sleep(0.3 * index)      # in this order
                result = await session.call_tool(
                    "variants", {"scene": str(PUSH_SCENE), "count": 1, "output": f"v{index}"},
                    progress_callback=progress[index])
                assert result.structured_content is not None
                bodies.append(result.structured_content)

            async with anyio.create_task_group() as group:
                for index in range(3):
                    group.start_soon(variants, index)
                while len(bodies) < 3:
                    busiest = max(busiest, len(server.workers()))
                    await anyio.sleep(0.05)

        server.run(scenario)
        assert [b["exit_status"] for b in bodies] == [0, 0, 0], bodies
        assert busiest == 1
        assert not any(m.startswith("queued") for m in progress[0].messages)
        assert progress[1].events[0] == (0, None, "queued: 1 of 1 worker processes busy, "
                                                  "0 calls ahead")
        assert progress[2].events[0] == (0, None, "queued: 1 of 1 worker processes busy, "
                                                  "1 call ahead")


@pytest.mark.slow
def test_a_verify_runs_at_most_as_many_jobs_as_workers(tmp_path: Path) -> None:
    root = make_project(tmp_path)
    with serving(root, "--workers", "2", "--allow-path", str(PUSH_BOX.parent)) as server:
        bodies: list[dict[str, object]] = []
        busiest = 0

        async def scenario(session: ClientSession) -> None:
            nonlocal busiest

            async def verify() -> None:
                result = await session.call_tool("verify", {
                    "path": str(PUSH_BOX), "scene": str(PUSH_SCENE), "variants": 1, **TINY,
                    "jobs": 256})
                assert result.structured_content is not None
                bodies.append(result.structured_content)

            async with anyio.create_task_group() as group:
                group.start_soon(verify)
                group.start_soon(verify)
                pid = None
                while len(bodies) < 2:
                    if pid is None and server.workers():
                        pid = _server_pid(server)
                    if pid is not None:
                        busiest = max(busiest, len(_descendants(pid)))
                    await anyio.sleep(0.05)

        server.run(scenario)
        for body in bodies:
            assert body["exit_status"] in (0, 1), body
            assert body["messages"][0] == (   # type: ignore[index]
                "rapidc mcp: jobs 256 lowered to 2, the worker processes this server runs at "
                "once (rapidc mcp --workers)")
        # one verify at a time: its process and its two jobs
        assert 1 <= busiest <= 3, busiest
