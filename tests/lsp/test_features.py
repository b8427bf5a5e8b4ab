"""The server's features one by one, through a running `rapidc lsp`: the YAML form, diagnostics of
used files, saving a used file, the path rules for `use`, completion contexts, and requests it
cannot answer."""

from __future__ import annotations

import re
from pathlib import Path
from typing import Any

import pytest

from rapid_dsl.language.files import MAX_INPUT_BYTES

from .client import Client, position

YAML = """\
- use: stdlib.push
- strategy: nudge
  goal: Push the box 5 cm toward the wall
  roles: {box: Object, table: Surface, wall: Fixture, hand: Manipulator}
  requires: ["on(box, table)", "reachable(hand, box)"]
  phases:
    - name: shove
      primitive: push
      roles: {target: box, support: table, hand: hand}
      args: {displacement: "5cm * direction(box, wall)"}
  success: ["distance(box, wall) < 0.05"]
"""


def at(uri: str, text: str, needle: str, after: int = 0) -> dict[str, Any]:
    return {"textDocument": {"uri": uri}, "position": position(text, needle, after)}


def write_open(client: Client, path: Path, text: str, language: str = "rapid") -> str:
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_text(text, encoding="utf-8")
    return client.open(path, text, language=language)


def labels(client: Client, uri: str, text: str, needle: str, after: int = 0) -> list[str]:
    result = client.request("textDocument/completion", at(uri, text, needle, after))
    return [item["label"] for item in result["items"]]


# ------------------------------------------------------------------------------- YAML form

@pytest.mark.slow
def test_yaml_form(server: Client, project: Path) -> None:
    uri = write_open(server, project / "nudge.rapid.yaml", YAML, language="yaml")
    [diagnostic] = server.diagnostics(uri)
    assert diagnostic["code"] == "E0302"
    assert diagnostic["range"] == {"start": position(YAML, "distance(box"),
                                   "end": position(YAML, '0.05"', after=4)}
    hover = server.request("textDocument/hover", at(uri, YAML, "* direction"))
    assert "`5cm * direction(box, wall)`: **Point**" in hover["contents"]["value"]
    hover = server.request("textDocument/hover", at(uri, YAML, "distance(box"))
    assert "distance(a: Body, b: Body) -> Length" in hover["contents"]["value"]
    target = server.request("textDocument/definition", at(uri, YAML, "push\n      roles"))
    assert target["uri"].endswith("/stdlib_primitives/push.rapid")
    target = server.request("textDocument/definition", at(uri, YAML, "box, wall) < 0.05"))
    assert target == {"uri": uri, "range": {"start": position(YAML, "box: Object"),
                                            "end": position(YAML, ": Object")}}
    assert {"box", "distance", "on"} <= set(labels(server, uri, YAML, "distance(box"))
    assert labels(server, uri, YAML, "push\n- strategy", after=0)[:1] == ["flip"]
    # a YAML program is not rewritten as .rapid text
    assert server.request("textDocument/formatting", {
        "textDocument": {"uri": uri}, "options": {"tabSize": 2, "insertSpaces": True}}) is None


# ------------------------------------------------------------------------ used files

@pytest.mark.slow
def test_errors_of_a_used_file_show_at_its_use(server: Client, project: Path) -> None:
    (project / "broken").mkdir()
    (project / "broken" / "lib.rapid").write_text("def broken(a: Body) -> Length =\n")
    (project / "broken" / "middle.rapid").write_text('use "lib.rapid"\n')
    text = 'use stdlib.push\nuse "broken/middle.rapid"\n'
    uri = write_open(server, project / "uses_broken.rapid", text)
    [diagnostic] = server.diagnostics(uri)
    assert diagnostic["code"] == "E0103"
    assert diagnostic["range"] == {"start": {"line": 1, "character": 0},
                                   "end": {"line": 1, "character": 25}}
    assert diagnostic["message"].startswith("broken/lib.rapid:2:1: ")
    [here] = diagnostic["relatedInformation"]
    assert here["location"]["uri"] == (project / "broken" / "lib.rapid").as_uri()
    assert here["location"]["range"]["start"] == {"line": 1, "character": 0}


def test_saving_a_used_file_checks_its_users_again(server: Client, project: Path) -> None:
    folder = project / "saving"
    lib = folder / "lib.rapid"
    lib_text = "def gap(a: Body, b: Body) -> Length = distance(a, b)\n"
    write_open(server, lib, lib_text)
    text = 'use "lib.rapid"\nrelation near(a: Body, b: Body) = gap(a, b) < 1cm\n'
    uri = write_open(server, folder / "user.rapid", text)
    assert server.diagnostics(uri) == []
    lib.write_text(lib_text.replace("gap", "spacing"), encoding="utf-8")
    server.notify("textDocument/didSave", {"textDocument": {"uri": lib.as_uri()}})
    [diagnostic] = server.diagnostics(uri)
    assert diagnostic["code"] == "E0201" and "`gap`" in diagnostic["message"]


def test_use_paths_follow_the_project_rules(server: Client, project: Path) -> None:
    """A `use` outside the document's folder tree is refused even when the file exists, and an
    unsaved buffer's relative `use` finds nothing (not the server's working folder)."""
    outside = project.parent / "outside.rapid"
    outside.write_text("def far(a: Body) -> Length = height(a)\n", encoding="utf-8")
    text = 'use "../../outside.rapid"\n'
    uri = write_open(server, project / "inner" / "escape.rapid", text)
    [diagnostic] = server.diagnostics(uri)
    assert diagnostic["code"] == "E0216"
    assert diagnostic["range"] == {"start": {"line": 0, "character": 4},
                                   "end": {"line": 0, "character": 25}}

    unsaved = "untitled:Untitled-1"
    server.notify("textDocument/didOpen", {"textDocument": {
        "uri": unsaved, "languageId": "rapid", "version": 1,
        "text": 'use "lib/helpers.rapid"\n'}})    # exists in the server's working folder
    [diagnostic] = server.diagnostics(unsaved)
    assert diagnostic["code"] == "E0206" and "no such file" in diagnostic["message"]


# ----------------------------------------------------------------------------- completion

PRIMITIVE = """\
use stdlib.push

primitive slide {
  goal "Slide the object"
  roles { target: Object, hand: Manipulator }
  params { gap: Length in [1cm, 5cm] = 2cm }
  resolve { d = distance(target, hand) }
  success { d < gap }
  cost final = (d / 1cm)^2
  motion { keypoint reach = pos(target) + 3cm * up; duration 2s }
}

strategy go {
  goal "Go"
  roles { box: Object, table: Surface, hand: Manipulator }
  requires { on(box, table); reachable(hand, box) }
  phase p: push(target=box, support=table, hand=hand) {
    displacement = 5cm * up
  }
  success { pos(box).z > 1cm }
}
"""


def test_completion_contexts(server: Client, project: Path) -> None:
    uri = write_open(server, project / "slide.rapid", PRIMITIVE)
    server.diagnostics(uri)
    # a primitive's expressions: its roles, params, resolved features and keypoints
    found = labels(server, uri, PRIMITIVE, "d < gap")
    assert {"target", "hand", "gap", "d", "reach", "distance", "pi"} <= set(found)
    assert "box" not in found                                  # the strategy's role
    assert found.index("target") < found.index("distance")     # names of the block first
    # a phase's primitive; its role map (`role=`) and, after `=`, the strategy's roles
    assert {"push", "slide"} <= set(labels(server, uri, PRIMITIVE, "push(target"))
    result = server.request("textDocument/completion", at(uri, PRIMITIVE, "target=box"))
    assert {i["label"]: i.get("insertText") for i in result["items"]} == {
        "target": "target=", "support": "support=", "hand": "hand="}
    assert set(labels(server, uri, PRIMITIVE, "box, support", after=0)) == \
        {"box", "table", "hand"}
    # units after a number, components after `.`, types after `:`
    assert {"cm", "deg", "kg"} <= set(labels(server, uri, PRIMITIVE, "cm * up", after=0))
    assert labels(server, uri, PRIMITIVE, "z > 1cm") == ["x", "y", "z"]
    assert {"Object", "Length", "Point"} <= set(labels(server, uri, PRIMITIVE, "Object, hand"))
    # keywords of a declaration at the start of a line
    assert {"success", "phase", "let"} <= set(labels(server, uri, PRIMITIVE, "success { pos"))


def hover_text(client: Client, uri: str, text: str, needle: str, after: int = 0) -> str:
    result = client.request("textDocument/hover", at(uri, text, needle, after))
    return result["contents"]["value"] if result else ""


def test_hover_and_definition_of_names(server: Client, project: Path) -> None:
    text = PRIMITIVE.replace("distance(target, hand)", "rotation(target, about=up)") \
        .replace("success { d < gap }", "success { abs(d) < 1rad }")
    uri = write_open(server, project / "names.rapid", text)
    server.diagnostics(uri)
    assert "param gap: Length in [1cm, 5cm] = 2cm" in hover_text(server, uri, text, "gap:")
    assert "resolved feature d: Angle" in hover_text(server, uri, text, "d = ")
    assert "**Angle** (SI unit rad)" in hover_text(server, uri, text, "d) <")
    assert "about: Direction" in hover_text(server, uri, text, "about=")
    assert "up: Direction" in hover_text(server, uri, text, "up)")
    assert "keypoint reach" in hover_text(server, uri, text, "reach =")
    assert "param displacement: Point" in hover_text(server, uri, text, "displacement =")
    assert "Push the target object" in hover_text(server, uri, text, "push\n")
    assert hover_text(server, uri, text, "p: push").startswith("phase `p`, which runs `push`")

    def target(needle: str, after: int = 0) -> dict[str, Any] | None:
        found = server.request("textDocument/definition", at(uri, text, needle, after))
        assert found is None or isinstance(found, dict)
        return found

    feature = target("d) <")
    assert feature is not None and feature["range"]["start"] == position(text, "d = ")
    assert target("about=") is None                                    # a builtin's parameter
    argument = target("displacement =")
    assert argument is not None and argument["uri"].endswith("/stdlib_primitives/push.rapid")
    role = target("support=table")
    assert role is not None and role["uri"] == argument["uri"]
    strategy_role = target("table, hand=hand")
    assert strategy_role is not None and \
        strategy_role["range"]["start"] == position(text, "table: Surface, hand")


MAIN_USE = 'use "lib/helpers.rapid"\n'


def test_definition_of_a_used_file(server: Client, project: Path) -> None:
    uri = write_open(server, project / "uses_file.rapid", MAIN_USE)
    server.diagnostics(uri)
    found = server.request("textDocument/definition", at(uri, MAIN_USE, "helpers"))
    assert found == {"uri": (project / "lib" / "helpers.rapid").as_uri(),
                     "range": {"start": {"line": 0, "character": 0},
                               "end": {"line": 0, "character": 0}}}


def test_completion_while_the_text_does_not_parse(server: Client, project: Path) -> None:
    """Names come from the last version that parsed."""
    path = project / "typing.rapid"
    uri = write_open(server, path, PRIMITIVE)
    server.diagnostics(uri)
    broken = PRIMITIVE.replace("success { d < gap }", "success { d < ")
    server.notify("textDocument/didChange", {"textDocument": {"uri": uri, "version": 2},
                                             "contentChanges": [{"text": broken}]})
    assert server.diagnostics(uri, version=2)[0]["code"].startswith("E01")
    found = labels(server, uri, broken, "d < ", after=4)
    assert {"gap", "d", "target"} <= set(found)


# --------------------------------------------------------------------- odd requests and input

def test_requests_it_cannot_answer(server: Client, project: Path) -> None:
    text = "strategy {\n"
    uri = write_open(server, project / "nothing.rapid", text)
    assert server.diagnostics(uri)
    for method in ("textDocument/hover", "textDocument/definition"):
        assert server.request(method, at(uri, text, "{")) is None
        assert server.request(method, {"textDocument": {"uri": uri},
                                       "position": {"line": 99, "character": 99}}) is None
        assert server.request(method, {"textDocument": {"uri": "file:///not/open.rapid"},
                                       "position": {"line": 0, "character": 0}}) is None
    assert server.request("textDocument/formatting", {
        "textDocument": {"uri": uri}, "options": {"tabSize": 2, "insertSpaces": True}}) == []
    assert "strategy" in labels(server, uri, text, "strategy")


@pytest.mark.parametrize("text", ["def f(a: Body) -> Real = 1\ud800\n", "goal \"\ud83e\"\n",
                                  "\x00\x1b[31m\u202e", "def f() -> Real = " + "(" * 3000])
def test_hostile_text_gets_diagnostics(server: Client, project: Path, text: str) -> None:
    """Lone surrogates, control characters and deep nesting are diagnostics, never a crash."""
    uri = (project / f"hostile_{abs(hash(text))}.rapid").as_uri()
    server.notify("textDocument/didOpen", {"textDocument": {
        "uri": uri, "languageId": "rapid", "version": 1, "text": text}})
    assert server.diagnostics(uri)
    for method in ("textDocument/hover", "textDocument/definition", "textDocument/completion"):
        server.request(method, {"textDocument": {"uri": uri},
                                "position": {"line": 0, "character": 20}})
    assert server.process.poll() is None


def test_a_document_over_the_input_limit_is_not_checked(server: Client, project: Path) -> None:
    text = "# " + "x" * MAX_INPUT_BYTES + "\n"
    uri = (project / "huge.rapid").as_uri()
    server.notify("textDocument/didOpen", {"textDocument": {
        "uri": uri, "languageId": "rapid", "version": 1, "text": text}})
    [diagnostic] = server.diagnostics(uri)
    assert "larger than the input limit of 10 MiB" in diagnostic["message"]
    assert server.request("textDocument/hover", at(uri, text, "x")) is None


LINTED = ("use stdlib.push\nstrategy s {\n  goal \"Push\"\n"
          "  roles { box: Object, table: Surface, hand: Manipulator, extra: Object }\n"
          "  requires { on(box, table); reachable(hand, box) }\n"
          "  phase p: push(target=box, support=table, hand=hand) { displacement = 5cm * up }\n"
          "}\n")


def test_lint_warnings_by_default(server: Client, project: Path) -> None:
    uri = write_open(server, project / "linted.rapid", LINTED)
    assert [d["code"] for d in server.diagnostics(uri)] == ["W0101"]


@pytest.mark.slow
def test_allow_path_and_no_lint(tmp_path: Path) -> None:
    """`--allow-path` (the command line's, never the client's) widens the tree `use` may read;
    the initialization option `lint: false` leaves lint warnings out."""
    (tmp_path / "shared").mkdir()
    (tmp_path / "shared" / "far.rapid").write_text("def far(a: Body) -> Length = height(a)\n")
    (tmp_path / "app").mkdir()
    text = 'use "../shared/far.rapid"\nrelation high(a: Body) = far(a) > 1m\n'
    client = Client("--allow-path", str(tmp_path / "shared"), cwd=tmp_path)
    try:
        client.initialize(tmp_path, options={"lint": False, "allowPath": ["/"]})
        uri = write_open(client, tmp_path / "app" / "main.rapid", text)
        assert client.diagnostics(uri) == []
        uri = write_open(client, tmp_path / "app" / "linted.rapid", LINTED)
        assert client.diagnostics(uri) == []
        uri = write_open(client, tmp_path / "elsewhere.rapid", 'use "app/../../x.rapid"\n')
        assert [d["code"] for d in client.diagnostics(uri)] == ["E0216"]
    finally:
        client.close()


def test_a_burst_of_changes_is_checked_at_its_end(server: Client, project: Path) -> None:
    """Changes closer together than the debounce give one check, of the newest text."""
    text = "relation near(a: Body, b: Body) = distance(a, b) < 1cm\n"
    uri = write_open(server, project / "burst.rapid", text)
    assert server.diagnostics(uri) == []
    for version in range(2, 12):
        bound = "1cm" if version < 11 else "1"
        server.notify("textDocument/didChange", {
            "textDocument": {"uri": uri, "version": version},
            "contentChanges": [{"text": text.replace("1cm", f"{bound}") + "#" * version}]})
    [diagnostic] = server.diagnostics(uri, version=11)
    assert diagnostic["code"] == "E0302"
    published = [m["params"]["version"] for m in server.seen
                 if m.get("method") == "textDocument/publishDiagnostics"
                 and m["params"]["uri"] == uri]
    assert published[0] == 1 and published[-1] == 11 and len(published) < 11


def test_a_bug_in_a_handler_answers_nothing(monkeypatch: pytest.MonkeyPatch) -> None:
    """In process: a handler that raises is logged, answers its default, and the server goes on."""
    from rapid_dsl.lsp.server import RapidServer

    server = RapidServer(())
    logged: list[str] = []
    monkeypatch.setattr(server, "log", logged.append)

    def broken(ls: RapidServer, params: object) -> str:
        raise KeyError("a bug")

    assert server.guard(broken, "default")(server, None) == "default"
    assert logged[0].startswith("internal error: KeyError: 'a bug'")
    assert "Traceback" not in logged[0]


def test_program_text_in_a_hover_is_not_markdown(server: Client, project: Path) -> None:
    """A goal or a file name is untrusted text: a hover shows it literally, so it cannot make the
    editor fetch an image or show a link of its own."""
    folder = project / "![x](https:"
    lib = folder / "evil.rapid"
    goal = "![track](https://example.invalid/t.png) [click](command:x) <img src=y> `code`"
    lib_text = (f'primitive evil {{\n  goal "{goal}"\n  roles {{ o: Object, hand: Manipulator }}\n'
                "  success { settled(o) }\n  cost final = 0\n"
                "  motion { keypoint k = pos(o); duration 1s }\n}\n")
    folder.mkdir(parents=True, exist_ok=True)
    lib.write_text(lib_text, encoding="utf-8")
    text = 'use "evil.rapid"\nstrategy s {\n  goal "g"\n  roles { b: Object, h: Manipulator }\n' \
        "  phase p: evil(o=b, hand=h)\n}\n"
    uri = write_open(server, folder / "user.rapid", text)
    server.diagnostics(uri)
    shown = hover_text(server, uri, text, "evil(o")
    assert "primitive evil(o: Object, hand: Manipulator)" in shown
    assert not re.search(r"(?<!\\)(!\[|\]\(|<img)", shown)       # nothing unescaped
    assert r"\!\[track\]\(https\:" in shown and r"\<img src\=y\>" in shown
