"""The tool table: every tool's parameters are its command's options, every string option is placed
(read, written or plain), and a new tool is one entry, nested commands included."""

from __future__ import annotations

from pathlib import Path

import pytest

from rapid_dsl.mcp import tools
from rapid_dsl.mcp.arguments import CallProblem, Workspace, prepared
from rapid_dsl.mcp.tools import ToolSpec

REPO = Path(__file__).resolve().parents[2]


@pytest.mark.parametrize("spec", tools.available(), ids=lambda s: s.name)
def test_every_string_option_of_a_tool_is_placed(spec: ToolSpec) -> None:
    # An option left out of reads, writes and plain is not offered (it might name a file the
    # server cannot keep in its folders): place it in the tool's entry in rapid_dsl/mcp/tools.py.
    assert tools.unplaced(spec) == []
    dests = {p.dest for p in tools.parameters(spec)}
    assert {*spec.reads, *spec.writes, *spec.texts} <= dests    # no typo in the entry
    assert not dests & tools.SERVER_OPTIONS


def test_an_unplaced_string_option_is_not_offered() -> None:
    bare = ToolSpec("bare_run", ("run",), reads=("program", "scene"))
    offered = {p.name for p in tools.parameters(bare)}
    assert "trace" not in offered and "video" not in offered
    assert {"trace", "video", "keyframes"} <= set(tools.unplaced(bare))
    assert {"samples", "best", "path", "scene"} <= offered   # typed options need no placing


def test_a_nested_command_is_one_entry(tmp_path: Path) -> None:
    spec = ToolSpec("bench_check", ("bench", "check"))
    schema = tools.input_schema(spec)
    assert schema["properties"]["lines"]["type"] == "integer"
    assert schema["properties"]["runs"]["type"] == "integer"
    with prepared(spec, {"lines": 200, "runs": 1}, Workspace(tmp_path)) as call:
        assert call.argv == ["bench", "check", "--format", "json", "--color", "never",
                             "--lines=200", "--runs=1"]


def test_an_optional_tool_is_listed_once_its_command_exists(monkeypatch: pytest.MonkeyPatch) \
        -> None:
    missing = ToolSpec("demo_nonesuch", ("nonesuch", "analyze"), optional=True)
    present = ToolSpec("schema_tool", ("schema",), optional=True)
    monkeypatch.setattr(tools, "TOOLS", (*tools.TOOLS, missing, present))
    names = [s.name for s in tools.available()]
    assert "demo_nonesuch" not in names and "schema_tool" in names


def test_arguments_become_the_command_line(tmp_path: Path) -> None:
    run = tools.spec_named("run")
    assert run is not None
    (tmp_path / "p.rapid").write_text("", encoding="utf-8")
    workspace = Workspace(tmp_path, allowed_dirs=(str(REPO / "examples"),))
    arguments = {"path": "p.rapid", "scene": str(REPO / "examples/scenes/push_box.yaml"),
                 "bind": {"box": "crate"}, "arg": ["angle=-90deg"], "samples": 8, "best": True,
                 "planning_dt": 0.004}
    with prepared(run, arguments, workspace) as call:
        assert call.argv[:6] == ["run", "--format", "json", "--color", "never",
                                 f"--allow-path={REPO / 'examples'}"]
        assert "--bind=box=crate" in call.argv and "--arg=angle=-90deg" in call.argv
        assert "--samples=8" in call.argv and "--best" in call.argv
        assert "--planning-dt=0.004" in call.argv
        assert call.argv[-2:] == ["--", "p.rapid"]
        trace = next(a for a in call.argv if a.startswith("--trace="))   # the result file
        assert call.folder is not None and trace == f"--trace={call.folder}/trace.json"
    assert not call.folder.exists()    # the temporary folder goes with the call


@pytest.mark.parametrize(("arguments", "message"), [
    ({"paths": ["a.rapid"], "strict": "yes"}, "`strict` is true or false"),
    ({"paths": ["a\0.rapid"]}, "NUL"),
    ({"paths": [7]}, None),     # a number is text here, as on a command line
    ({"text": "x", "name": "a.txt"}, "a program's name ends in .rapid"),
    ({"text": "\ud800"}, "lone surrogate"),
    ({"paths": ["/"]}, "outside the folders"),
])
def test_bad_arguments_are_refused_before_anything_runs(tmp_path: Path, arguments: dict,
                                                        message: str | None) -> None:
    check = tools.spec_named("check")
    assert check is not None
    if message is None:
        with prepared(check, arguments, Workspace(tmp_path)) as call:
            assert call.argv[-1] == "7"
        return
    with pytest.raises(CallProblem, match=message), \
            prepared(check, arguments, Workspace(tmp_path)):
        pass
