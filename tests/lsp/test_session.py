"""One editor session with `rapidc lsp`, as an editor would run it: initialize, open a program with
an error, ask for hover, definition, completion and formatting, fix the error with an incremental
change, shut down."""

from __future__ import annotations

from pathlib import Path
from typing import Any

import pytest

from rapid_dsl.frontend.formatter import format_source

from .client import Client, position
from .conftest import MAIN, make_project


def _at(uri: str, text: str, needle: str, after: int = 0) -> dict[str, Any]:
    return {"textDocument": {"uri": uri}, "position": position(text, needle, after)}


@pytest.mark.slow
def test_an_editor_session(tmp_path: Path) -> None:
    project = make_project(tmp_path)
    client = Client(cwd=project)
    try:
        result = client.initialize(project)
        capabilities = result["capabilities"]
        assert capabilities["positionEncoding"] == "utf-16"
        assert capabilities["textDocumentSync"]["change"] == 2   # incremental
        assert capabilities["hoverProvider"] and capabilities["definitionProvider"]
        assert capabilities["documentFormattingProvider"]
        assert "." in capabilities["completionProvider"]["triggerCharacters"]
        assert result["serverInfo"]["name"] == "rapidc"

        main = project / "main.rapid"
        uri = client.open(main)
        published = client.wait_for("textDocument/publishDiagnostics", uri)
        assert published["version"] == 1
        [diagnostic] = published["diagnostics"]
        assert diagnostic["code"] == "E0302"
        assert diagnostic["severity"] == 1
        assert diagnostic["source"] == "rapidc"
        assert diagnostic["range"] == {"start": {"line": 11, "character": 12},
                                       "end": {"line": 11, "character": 38}}
        assert diagnostic["message"].startswith("cannot compare Length with Real")
        assert "help: give the bound a unit, e.g. `5cm`" in diagnostic["message"]

        # hover: a builtin's signature from the registry and the call's type
        hover = client.request("textDocument/hover", _at(uri, MAIN, "distance(box, wall) <"))
        value = hover["contents"]["value"]
        assert hover["contents"]["kind"] == "markdown"
        assert "distance(a: Body, b: Body) -> Length" in value
        assert "This call: **Length** (SI unit m)" in value
        assert hover["range"] == {"start": {"line": 11, "character": 12},
                                  "end": {"line": 11, "character": 20}}
        # hover: the type and dimension of an expression (the `*` of the displacement)
        hover = client.request("textDocument/hover", _at(uri, MAIN, "* direction"))
        assert "**Point**, a vector of Length (SI unit m)" in hover["contents"]["value"]
        assert hover["range"]["start"] == position(MAIN, "(clearance(box")

        # go to definition across `use`: a file's def, and a standard-library primitive
        target = client.request("textDocument/definition", _at(uri, MAIN, "clearance("))
        assert target == {"uri": (project / "lib" / "helpers.rapid").as_uri(),
                          "range": {"start": {"line": 0, "character": 4},
                                    "end": {"line": 0, "character": 13}}}
        target = client.request("textDocument/definition", _at(uri, MAIN, "push(target"))
        assert target["uri"].endswith("/rapid_dsl/stdlib_primitives/push.rapid")
        assert Path(target["uri"].removeprefix("file://")).is_file()

        # completion: builtins, roles, the let and the used def in an expression...
        items = client.request("textDocument/completion",
                               _at(uri, MAIN, "distance(box, wall) <"))["items"]
        labels = {item["label"]: item for item in items}
        assert {"distance", "on", "up", "box", "wall", "margin", "clearance"} <= set(labels)
        assert labels["distance"]["detail"] == "distance(a: Body, b: Body) -> Length"
        assert labels["box"]["detail"] == "role: Object"
        # ... the params of the phase's primitive at the start of an argument line...
        items = client.request("textDocument/completion",
                               _at(uri, MAIN, "displacement ="))["items"]
        assert [i["label"] for i in items] == ["displacement", "contact_height", "clearance"]
        # ... and standard-library names after `use stdlib.`
        items = client.request("textDocument/completion",
                               _at(uri, MAIN, "push\n", after=0))["items"]
        assert {"push", "flip", "grasp"} <= {i["label"] for i in items}

        # formatting: the canonical text, as `rapidc fmt`
        edits = client.request("textDocument/formatting", {
            "textDocument": {"uri": uri}, "options": {"tabSize": 2, "insertSpaces": True}})
        formatted, _ = format_source(MAIN, str(main))
        [edit] = edits
        assert edit["newText"] == formatted and "  let margin = 1cm\n" in formatted
        assert edit["range"] == {"start": {"line": 0, "character": 0},
                                 "end": {"line": 13, "character": 0}}

        # an incremental change gives the bound a unit: the error goes
        start = position(MAIN, "0.05")
        client.notify("textDocument/didChange", {
            "textDocument": {"uri": uri, "version": 2},
            "contentChanges": [{"range": {"start": start, "end": {
                "line": start["line"], "character": start["character"] + 4}}, "text": "5cm"}]})
        assert client.diagnostics(uri, version=2) == []
        hover = client.request("textDocument/hover", _at(uri, MAIN.replace("0.05", "5cm"),
                                                         "5cm }"))
        assert "**Length** (SI unit m)" in hover["contents"]["value"]

        assert client.request("shutdown") is None
        client.notify("exit")
        assert client.wait() == 0
    finally:
        if client.process.poll() is None:
            client.process.kill()
            client.process.wait()
