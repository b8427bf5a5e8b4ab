"""`rapidc mcp` over stdio, driven by the MCP SDK's own client: tools, resources, the same JSON as
the command line, path rules, inline texts, progress, cancellation and error isolation."""

from __future__ import annotations

import json
import os
import subprocess
import sys
import time
from pathlib import Path

import anyio
import jsonschema
import pytest
from conftest import NUDGE, PUSH_BOX, PUSH_SCENE, REPO, Progress, Server, make_project, serving
from mcp import ClientSession

from rapid_dsl.cli import main
from rapid_dsl.language.codes import CODES
from rapid_dsl.language.registry import BUILTINS

TOOLS = {"check", "lint", "fmt", "compile", "bind", "run", "verify", "variants", "explain"}
TINY = {"samples": 8, "iterations": 1}   # the smallest budgets: seconds, not minutes


@pytest.mark.slow
def test_it_lists_its_tools_with_the_command_lines_options(server: Server) -> None:
    listed = server.portal.call(server.session.list_tools).tools
    names = {t.name for t in listed}
    assert TOOLS <= names
    run = next(t for t in listed if t.name == "run")
    props = run.input_schema["properties"]
    assert props["samples"]["type"] == "integer"
    assert props["best"]["type"] == "boolean"
    assert props["path"]["type"] == "string" and "text" in props and "scene_text" in props
    assert {"type": "object", "additionalProperties": {"type": "string"}} in \
        props["bind"]["anyOf"]
    # what the server decides is not a parameter
    assert not {"format", "color", "allowed_dirs", "allow_path", "cluster"} & set(props)
    verify = next(t for t in listed if t.name == "verify")
    assert "variants" in verify.input_schema["required"]
    assert "cluster" not in verify.input_schema["properties"]
    assert all(t.output_schema is not None for t in listed)


@pytest.mark.slow
def test_it_lists_and_reads_its_resources(server: Server) -> None:
    uris = {r.uri for r in server.portal.call(server.session.list_resources).resources}
    assert {"rapid://card", "rapid://builtins", "rapid://diagnostics", "rapid://language",
            "rapid://stdlib/push", "rapid://stdlib/flip"} <= uris

    def read(uri: str) -> str:
        contents = server.portal.call(server.session.read_resource, uri).contents
        return str(contents[0].text)   # type: ignore[union-attr]

    card = read("rapid://card")
    assert card.startswith("# The RAPID language card") and "`push(" in card
    assert {b["name"] for b in json.loads(read("rapid://builtins"))} == set(BUILTINS)
    assert {c["code"] for c in json.loads(read("rapid://diagnostics"))} == set(CODES)
    assert read("rapid://stdlib/push") == \
        (REPO / "stdlib_primitives" / "push.rapid").read_text(encoding="utf-8")
    assert read("rapid://language").startswith("# The RAPID language reference")


def test_check_returns_the_diagnostics_the_command_line_prints(
        server: Server, project: Path, capsys: pytest.CaptureFixture[str],
        monkeypatch: pytest.MonkeyPatch) -> None:
    body = server.body("check", {"paths": ["nudge.rapid"]})
    assert body["exit_status"] == 1     # program errors: a result, not a failed call
    assert [(d["code"], d["line"], d["column"]) for d in body["diagnostics"]] == [
        ("E0508", 8, 20), ("E0302", 10, 13)]
    assert body["diagnostics"][1]["help"] == "give the bound a unit, e.g. `5cm`"
    monkeypatch.chdir(project)
    assert main(["check", "--format", "json", "nudge.rapid"]) == 1
    assert body["diagnostics"] == json.loads(capsys.readouterr().out)
    linted = server.body("lint", {"paths": "lib"})   # a folder; one path may be a string
    assert linted["exit_status"] == 0     # warnings fail only with `strict`
    assert [(d["file"], d["code"]) for d in linted["diagnostics"]] == [("lib/ok.rapid", "W0105")]
    assert server.body("lint", {"paths": "lib", "strict": True})["exit_status"] == 1


def test_inline_text_is_checked_under_its_name(server: Server) -> None:
    result = server.call("check", {"text": NUDGE, "name": "tour.rapid"})
    body = result.structured_content
    assert body is not None and not result.is_error
    assert {d["file"] for d in body["diagnostics"]} == {"tour.rapid"}
    assert "rapidc-mcp-" not in result.content[0].text    # the temporary folder is left out
    formatted = server.body("fmt", {"text": "use stdlib.push\nrelation near(a: Body, b: Body)="
                                            "distance(a,b)<5cm\n"})
    assert formatted["output"] == ("use stdlib.push\n\nrelation near(a: Body, b: Body) = "
                                   "distance(a, b) < 5cm\n")
    yaml = server.body("check", {"text": "- use: stdlib.pushh\n", "name": "p.rapid.yaml"})
    assert [(d["file"], d["code"]) for d in yaml["diagnostics"]] == [("p.rapid.yaml", "E0205")]


def test_a_bad_path_is_a_clean_error_result(server: Server, tmp_path: Path) -> None:
    missing = server.call("check", {"paths": ["nope.rapid"]})
    assert missing.is_error
    assert missing.structured_content is not None
    assert missing.structured_content["exit_status"] == 2
    assert missing.structured_content["messages"] == [
        "rapidc: error: no such file or folder: nope.rapid"]
    outside = tmp_path / "elsewhere.rapid"
    outside.write_text(NUDGE, encoding="utf-8")
    refused = server.body("check", {"paths": [str(outside)]})
    assert refused["exit_status"] == 2
    assert "outside the folders this server may use" in refused["messages"][0]
    # an output may not go outside either, nor into the standard library
    assert "outside" in server.body("compile", {"path": "lib/ok.rapid",
                                                "output": str(tmp_path)})["messages"][0]
    stdlib = server.body("fmt", {"paths": [str(REPO / "stdlib_primitives" / "push.rapid")],
                                 "write": True})
    assert "may be read, not written" in stdlib["messages"][0]
    assert not any(tmp_path.iterdir()) or list(tmp_path.iterdir()) == [outside]
    # the server goes on
    assert server.body("check", {"paths": ["lib/ok.rapid"]})["exit_status"] == 0


def test_bad_arguments_are_error_results(server: Server) -> None:
    cases = [
        ("check", {"pahts": ["nudge.rapid"]}, "unknown argument `pahts`"),
        ("run", {"path": "lib/ok.rapid", "scene": str(PUSH_SCENE), "samples": "8"},
         "`samples` is an integer"),
        ("check", {"paths": "nudge.rapid", "name": "x.rapid"}, "give `text` too"),
        ("compile", {"path": "lib/ok.rapid", "text": NUDGE}, "not both"),
        ("check", {"text": NUDGE, "name": "../x.rapid"}, "a plain file name"),
        ("run", {"scene": str(PUSH_SCENE)}, "missing argument `path` (or `text`)"),
        ("verify", {"path": "lib/ok.rapid", "scene": str(PUSH_SCENE), "variants": 1,
                    "samples": 100000}, "must be at most"),   # the command line's own check
        ("nonesuch", {}, "no tool `nonesuch`"),
    ]
    for tool, arguments, message in cases:
        result = server.call(tool, arguments)
        assert result.is_error, (tool, arguments)
        assert result.structured_content is not None
        assert message in "\n".join(result.structured_content["messages"]), result


def test_quick_tools_return_what_the_commands_print(server: Server) -> None:
    explain = server.body("explain", {"code": "e0302"})
    assert explain["output"] == f"E0302: {CODES['E0302']}\n"
    module = server.body("compile", {"path": "lib/ok.rapid"})
    assert module["exit_status"] == 0 and module["output"].startswith("# Generated by rapidc")
    broken = server.body("compile", {"path": "nudge.rapid"})
    assert broken["exit_status"] == 1
    assert [d["code"] for d in broken["diagnostics"]] == ["E0508", "E0302"]
    ranking = server.body("bind", {"path": str(PUSH_BOX), "scene": str(PUSH_SCENE),
                                   "bind": {"box": "box"}})
    assert ranking["exit_status"] == 0
    assert ranking["result"]["bindings"][0]["binding"] == {"box": "box", "table": "table",
                                                           "hand": "gripper"}


@pytest.mark.slow
def test_run_returns_the_trace_and_reports_progress(server: Server, project: Path) -> None:
    progress = Progress()
    body = server.body("run", {"path": str(PUSH_BOX), "scene": str(PUSH_SCENE), **TINY,
                               "track": "push.track.json"}, progress)
    assert body["exit_status"] in (0, 1), body["messages"]
    trace = body["result"]
    assert trace["entry"] == "push_box"
    assert [(p["name"], p["samples"], p["iterations"]) for p in trace["phases"]] == [
        ("shove", 8, 1)]
    assert "push_box (strategy) on" in body["output"]
    assert "phase shove: iteration 1/1, best cost" in "\n".join(progress.messages)
    values = [p for p, _, _ in progress.events]
    assert values == sorted(set(values))      # progress only goes up
    assert not any(m.startswith("phase ") for m in body["messages"])
    # the track it wrote is demo_analyze's input
    analysis = server.body("demo_analyze", {"track": "push.track.json",
                                            "skeleton": "skeleton.rapid"})
    assert analysis["exit_status"] == 0, analysis["messages"]
    assert analysis["result"]["phases"] and (project / "skeleton.rapid").is_file()


@pytest.mark.slow
def test_verify_returns_the_report_and_reports_each_run(server: Server) -> None:
    progress = Progress()
    body = server.body("verify", {"path": str(PUSH_BOX), "scene": str(PUSH_SCENE),
                                  "variants": 2, **TINY}, progress)
    assert body["exit_status"] in (0, 1), body["messages"]
    report = body["result"]
    assert report["summary"]["runs"] == 3 and report["complete"]
    schema = json.loads((REPO / "rapid_dsl" / "runtime" / "verification" / "report.schema.json")
                        .read_text(encoding="utf-8"))
    jsonschema.validate(report, schema)
    assert [(p, t) for p, t, _ in progress.events] == [(1, 3), (2, 3), (3, 3)]
    assert progress.messages[0].startswith("verify: 1/3 the scene: ")


@pytest.mark.slow
def test_inline_program_and_scene_run(server: Server) -> None:
    body = server.body("run", {"text": PUSH_BOX.read_text(encoding="utf-8"),
                               "scene_text": PUSH_SCENE.read_text(encoding="utf-8"), **TINY})
    assert body["exit_status"] in (0, 1), body["messages"]
    assert body["result"]["scene"] == "scene.yaml"


@pytest.mark.slow
def test_a_cancelled_verify_stops_and_the_server_stays_responsive(server: Server,
                                                                  project: Path) -> None:
    report = project / "cancelled.json"

    async def scenario(session: ClientSession) -> float:
        started = anyio.Event()

        async def first(progress: float, total: float | None, message: str | None) -> None:
            started.set()

        async with anyio.create_task_group() as group:
            async def verify() -> None:
                await session.call_tool("verify", {
                    "path": str(PUSH_BOX), "scene": str(PUSH_SCENE), "variants": 200,
                    "report": report.name, **TINY}, progress_callback=first)
                raise AssertionError("200 variants finished before the cancellation")

            group.start_soon(verify)
            with anyio.fail_after(60):
                await started.wait()
            # while verify runs in its worker, a quick call is answered at once
            clock = time.perf_counter()
            checked = await session.call_tool("check", {"paths": ["lib/ok.rapid"]})
            seconds = time.perf_counter() - clock
            assert checked.structured_content is not None
            assert checked.structured_content["exit_status"] == 0
            group.cancel_scope.cancel()   # the client cancels the verify request
        return seconds

    assert server.run(scenario) < 5.0
    # the worker was interrupted as by Ctrl-C: verify wrote what it had finished
    deadline = time.monotonic() + 30
    while not report.exists() and time.monotonic() < deadline:
        time.sleep(0.2)
    written = json.loads(report.read_text(encoding="utf-8"))
    assert written["complete"] is False and written["summary"]["runs"] < 201
    while server.workers() and time.monotonic() < deadline:
        time.sleep(0.2)
    assert server.workers() == []       # and its worker process is gone
    assert server.body("explain", {"code": "E0101"})["exit_status"] == 0
    assert "Traceback" not in server.stderr()


@pytest.mark.slow
def test_allow_path_on_the_command_line_applies_to_every_call(tmp_path: Path) -> None:
    root, library = tmp_path / "root", tmp_path / "library"
    root.mkdir()
    library.mkdir()
    (library / "near.rapid").write_text("relation near(a: Body, b: Body) = distance(a, b) < 5cm\n",
                                        encoding="utf-8")
    program = root / "main.rapid"
    program.write_text('use "../library/near.rapid"\n', encoding="utf-8")
    with serving(root) as alone:
        used = alone.body("check", {"paths": ["main.rapid"]})
        assert [d["code"] for d in used["diagnostics"]] == ["E0216"]   # use outside the folder
        assert alone.body("check", {"paths": [str(library)]})["exit_status"] == 2
    with serving(root, "--allow-path", str(library)) as allowed:
        assert allowed.body("check", {"paths": ["main.rapid"]})["exit_status"] == 0
        assert allowed.body("check", {"paths": [str(library)]})["exit_status"] == 0
        assert "Traceback" not in allowed.stderr()


def test_check_round_trip_is_quick_after_start(server: Server) -> None:
    from rapid_dsl.bench.check import generate_strategy_file

    (server.root / "long.rapid").write_text(generate_strategy_file(200), encoding="utf-8")
    assert server.body("check", {"paths": ["long.rapid"]})["exit_status"] == 0   # warm
    times = []
    for _ in range(5):
        clock = time.perf_counter()
        server.call("check", {"paths": ["long.rapid"]})
        times.append(time.perf_counter() - clock)
    # about 30 ms here; the bound only catches a call that starts a process or re-imports
    assert sorted(times)[2] < 0.5, times


@pytest.mark.slow
def test_scene_from_rgbd_reconstructs_a_rendered_frame(server: Server, project: Path) -> None:
    frame = project / "frame"
    rendered = subprocess.run(
        [sys.executable, "-m", "rapid_dsl", "scene", "render", str(PUSH_SCENE), "-o", str(frame)],
        capture_output=True, text=True, env={**os.environ, "MUJOCO_GL": "egl"}, check=False)
    if rendered.returncode != 0:
        pytest.skip(f"no offscreen GL to render a frame: {rendered.stderr.strip()[-200:]}")
    files = {name: f"frame/{name}.json" for name in ("intrinsics", "extrinsics", "labels")}
    body = server.body("scene_from_rgbd", {"rgb": "frame/rgb.png", "depth": "frame/depth.png",
                                           "masks": "frame/masks", "output": "rebuilt.yaml",
                                           **files})
    assert body["exit_status"] == 0, body["messages"]
    assert body["result"]["support"]["name"] == "table"
    assert [o["name"] for o in body["result"]["objects"]] == ["box"]
    assert (project / "rebuilt.yaml").is_file()
    outside = server.body("scene_from_rgbd", {"rgb": "frame/rgb.png", "depth": "/etc/hostname",
                                              "masks": "frame/masks", "output": "x.yaml",
                                              "intrinsics": files["intrinsics"]})
    assert outside["exit_status"] == 2 and "outside the folders" in outside["messages"][0]


@pytest.mark.slow
def test_workers_render_with_the_users_gl_back_end(tmp_path: Path) -> None:
    # The server runs without GL, as every command; its workers get the MUJOCO_GL it was started
    # with, for run's key frames and verify's media (and end without a traceback).
    root = make_project(tmp_path)
    with serving(root, "--allow-path", str(PUSH_BOX.parent), env={"MUJOCO_GL": "egl"}) as egl:
        body = egl.body("run", {"path": str(PUSH_BOX), "scene": str(PUSH_SCENE), **TINY,
                                "keyframes": "frames"})
        if body["exit_status"] == 2 and "rendering is unavailable" in body["messages"][0]:
            pytest.skip(body["messages"][0])
        assert body["messages"] == ["wrote 5 key frames to frames"]
        media = egl.body("verify", {"path": str(PUSH_BOX), "scene": str(PUSH_SCENE),
                                    "variants": 1, **TINY, "media": "media"})
        assert media["exit_status"] in (0, 1), media["messages"]
        assert sorted(p.name for p in (root / "media").iterdir()) == ["scene.png",
                                                                      "variant-0000.png"]
        assert "Traceback" not in egl.stderr()


CUBE = "\n".join([f"v {x} {y} {z}" for x in (0, 1) for y in (0, 1) for z in (0, 1)]
                 + [f"f {a} {b} {c}" for a, b, c in (
                     (1, 3, 4), (1, 4, 2), (5, 6, 8), (5, 8, 7), (1, 2, 6), (1, 6, 5),
                     (3, 7, 8), (3, 8, 4), (1, 5, 7), (1, 7, 3), (2, 4, 8), (2, 8, 6))]) + "\n"
CUBE_SCENE = """\
robot: floating_gripper
floor_height: -0.75
objects:
  - {name: table, kind: surface, shape: box, size: [1.0, 1.2, 0.75],
     pose: {position: [0.55, 0.0, -0.375]}}
  - {name: block, kind: object, shape: mesh, mesh: meshes/cube.obj, size: [0.05, 0.05, 0.05],
     pose: {position: [0.5, 0.1, 0.025]}, mass: 0.1}
"""


@pytest.mark.slow
def test_tool_outputs_stay_below_their_folder_and_off_the_inputs(tmp_path: Path) -> None:
    """Regression: the `variants` tool wrote OUT/meshes/ through a `meshes` symlink out of the
    server's root, and the `verify` tool's `html` replaced the ranges file or a used file."""
    root, elsewhere = tmp_path / "root", tmp_path / "elsewhere"
    (root / "scene" / "meshes").mkdir(parents=True)
    (root / "lib").mkdir()
    elsewhere.mkdir()
    (root / "scene" / "meshes" / "cube.obj").write_text(CUBE, encoding="utf-8")
    (root / "scene" / "cubes.yaml").write_text(CUBE_SCENE, encoding="utf-8")
    (root / "vout").mkdir()
    (root / "vout" / "meshes").symlink_to(elsewhere)
    near = "relation near(a: Body, b: Body) = distance(a, b) < 5cm\n"
    (root / "lib" / "near.rapid").write_text(near, encoding="utf-8")
    (root / "main.rapid").write_text('use "lib/near.rapid"\n' + PUSH_BOX.read_text(),
                                     encoding="utf-8")
    (root / "ranges.yaml").write_text("{}\n", encoding="utf-8")
    with serving(root, "--allow-path", str(PUSH_SCENE.parent)) as tools:
        variants = tools.body("variants", {"scene": "scene/cubes.yaml", "count": 2,
                                           "output": "vout"})
        assert variants["exit_status"] == 2, variants
        assert "vout/meshes: is a symbolic link; refusing to write through it" in \
            variants["messages"][0]
        assert list(elsewhere.iterdir()) == []
        for page in ("ranges.yaml", "lib/near.rapid"):
            verify = tools.body("verify", {"path": "main.rapid", "scene": str(PUSH_SCENE),
                                           "ranges": "ranges.yaml", "variants": 1, **TINY,
                                           "html": page})
            assert verify["exit_status"] == 2
            assert f"--html {page}: it is one of the inputs" in verify["messages"][0]
        assert (root / "ranges.yaml").read_text(encoding="utf-8") == "{}\n"
        assert (root / "lib" / "near.rapid").read_text(encoding="utf-8") == near
        assert "Traceback" not in tools.stderr()
