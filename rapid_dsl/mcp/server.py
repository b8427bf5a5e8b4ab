"""The MCP server: the tools of tools.py and the resources of resources.py, over stdio.

Built on the `mcp` SDK's low-level server (the tools' schemas come from the commands' parsers,
not from Python signatures). A tool's result is the call's JSON (tools.OUTPUT_SCHEMA) as
structured content plus the same JSON as text; `isError` is set for bad input and internal
errors (exit status 2 or more), not for programs with errors or runs that failed. Progress of
run, verify and variants goes out as progress notifications when the client asks for them.
"""

from __future__ import annotations

import json
import sys
import traceback
from contextlib import suppress
from typing import Any

from mcp import types
from mcp.server.lowlevel import Server

from rapid_dsl import __version__
from rapid_dsl.frontend.driver import deep_recursion
from rapid_dsl.mcp import calls, capture, resources, tools, transport
from rapid_dsl.mcp.arguments import Workspace
from rapid_dsl.mcp.results import is_error, problem
from rapid_dsl.mcp.slots import Pools, pools

INSTRUCTIONS = """\
rapidc: a typed language for robot manipulation programs (.rapid), its compiler and a MuJoCo
runner. Read the resource rapid://card before writing a program. Then: check (or lint) it and fix
its diagnostics, run it on a scene, verify it on seeded variants of the scene, and revise it from
the first failing clause of the verify report. A tool takes the command line's options as JSON
(`"samples": 8`, `"bind": {"role": "entity"}`) and returns what the command prints with
--format json. Paths are relative to {root}; a program may also be given as `text`."""


def build(workspace: Workspace, gl_backend: str, running: Pools) -> Server[Any]:
    """The server; `gl_backend` is the user's MUJOCO_GL, for the worker processes; `running`
    holds what runs at once."""
    specs = tools.available()

    async def list_tools(ctx: Any, params: Any) -> types.ListToolsResult:
        return types.ListToolsResult(tools=[
            types.Tool(name=s.name, title=f"rapidc {' '.join(s.command)}",
                       description=tools.describe(s), input_schema=tools.input_schema(s),
                       output_schema=tools.OUTPUT_SCHEMA,
                       annotations=types.ToolAnnotations(read_only_hint=s.read_only,
                                                         open_world_hint=False))
            for s in specs])

    async def call_tool(ctx: Any, params: types.CallToolRequestParams) -> types.CallToolResult:
        spec = next((s for s in specs if s.name == params.name), None)
        if spec is None:
            body = problem(params.name, f"no tool `{params.name}`; the tools are "
                                        + ", ".join(s.name for s in specs))
            return _result(body)

        async def report(progress: float, total: float | None, message: str) -> None:
            with suppress(Exception):   # a client that went away does not stop the run
                await ctx.session.report_progress(progress, total, message)

        try:
            body = await calls.call(spec, dict(params.arguments or {}), workspace, report,
                                    gl_backend, running)
        except Exception as exc:  # noqa: BLE001 - a bug in one call must not stop the server
            traceback.print_exc(file=sys.stderr)
            body = problem(spec.name, f"internal error: {type(exc).__name__}: {exc}", status=3)
        return _result(body)

    async def list_resources(ctx: Any, params: Any) -> types.ListResourcesResult:
        return types.ListResourcesResult(resources=[
            types.Resource(name=e.name, uri=e.uri, description=e.description,
                           mime_type=e.mime_type)
            for e in resources.entries()])

    async def read_resource(ctx: Any,
                            params: types.ReadResourceRequestParams) -> types.ReadResourceResult:
        entry = resources.find(str(params.uri))
        if entry is None:
            from mcp.shared.exceptions import MCPError

            raise MCPError(types.INVALID_PARAMS, f"no resource {params.uri}; list them with "
                                                 "resources/list")
        return types.ReadResourceResult(contents=[
            types.TextResourceContents(uri=entry.uri, mime_type=entry.mime_type,
                                       text=entry.read())])

    return Server("rapidc", version=__version__, title="rapidc",
                  instructions=INSTRUCTIONS.replace("{root}", str(workspace.root)),
                  on_list_tools=list_tools, on_call_tool=call_tool,
                  on_list_resources=list_resources, on_read_resource=read_resource)


def _result(body: dict[str, Any]) -> types.CallToolResult:
    return types.CallToolResult(
        content=[types.TextContent(type="text", text=json.dumps(body, ensure_ascii=False))],
        structured_content=body, is_error=is_error(body["exit_status"]))


async def serve(workspace: Workspace, gl_backend: str, workers: int) -> None:
    """Serve over this process's stdin and stdout until the client closes them, running at most
    `workers` worker processes at once."""
    server = build(workspace, gl_backend, pools(workers))
    # Quick commands run in several threads at once: the recursion limit they raise while they
    # run (driver.deep_recursion) is raised for the whole server, so none lowers it under another.
    with deep_recursion():
        async with transport.stdio() as (read_stream, write_stream):
            # after the transport took the real stdout: from here on a print reaches stderr at most
            restore = capture.install()
            try:
                await server.run(read_stream, write_stream,
                                 server.create_initialization_options())
            finally:
                restore()
