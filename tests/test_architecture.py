"""The package's import graph keeps the layers of docs/architecture.md: no cycles between modules,
and each layer imports only the layers below it.

Read statically from every `import` of every module, those inside functions included, so an
import deferred for start-up time counts like any other. Imports under `if TYPE_CHECKING:` are
left out: they never run, and they are how a module names a type of a module that uses it.
"""

from __future__ import annotations

import ast
import os
from pathlib import Path

import pytest

PACKAGE = Path(__file__).resolve().parents[1] / "rapid_dsl"

# Layer of a module: the first prefix that matches. Lower layers come first.
LAYERS = [
    ("language", ("rapid_dsl.language", "rapid_dsl.grammar", "rapid_dsl.stdlib_primitives")),
    ("frontend", ("rapid_dsl.frontend",)),
    ("compiler", ("rapid_dsl.compiler",)),
    ("runtime", ("rapid_dsl.runtime",)),
    ("api", ("rapid_dsl.api",)),
    ("services", ("rapid_dsl.lsp", "rapid_dsl.mcp")),
    ("cli", ("rapid_dsl.commands", "rapid_dsl.cli", "rapid_dsl.__main__", "rapid_dsl.bench")),
]
# What each layer may import besides itself.
ALLOWED = {
    "language": set(),
    "frontend": {"language"},
    "compiler": {"language", "frontend", "runtime"},   # the generated module's imports and ABI
    "runtime": {"language"},
    "api": {"language", "frontend", "compiler", "runtime"},
    "services": {"language", "frontend", "compiler", "runtime", "api"},
    "cli": {"language", "frontend", "compiler", "runtime", "api", "services"},
}


def _modules() -> dict[str, Path]:
    out: dict[str, Path] = {}
    for folder, _, files in os.walk(PACKAGE, followlinks=True):   # runtime/ etc. are symlinks
        for name in files:
            if name.endswith(".py"):
                path = Path(folder) / name
                parts = ["rapid_dsl", *path.relative_to(PACKAGE).with_suffix("").parts]
                out[".".join(parts[:-1] if parts[-1] == "__init__" else parts)] = path
    return out


MODULES = _modules()


def _resolve(name: str) -> str:
    while name not in MODULES:
        name = name.rpartition(".")[0]
    return name


def _typing_only(tree: ast.Module) -> set[int]:
    """The ids of the import nodes inside `if TYPE_CHECKING:` blocks."""
    return {id(node) for block in ast.walk(tree) if isinstance(block, ast.If)
            and isinstance(block.test, ast.Name) and block.test.id == "TYPE_CHECKING"
            for statement in block.body for node in ast.walk(statement)}


def _imports(module: str, path: Path) -> set[str]:
    found: set[str] = set()
    package = module if path.name == "__init__.py" else module.rpartition(".")[0]
    tree = ast.parse(path.read_text(encoding="utf-8"))
    typing_only = _typing_only(tree)
    for node in ast.walk(tree):
        if id(node) in typing_only:
            continue
        if isinstance(node, ast.Import):
            found.update(_resolve(a.name) for a in node.names if a.name.startswith("rapid_dsl"))
        elif isinstance(node, ast.ImportFrom):
            base = node.module or ""
            if node.level:
                parts = package.split(".")[: len(package.split(".")) - node.level + 1]
                base = ".".join([*parts, base] if base else parts)
            if base.startswith("rapid_dsl"):
                for a in node.names:
                    full = f"{base}.{a.name}"
                    found.add(_resolve(full if full in MODULES else base))
    found.discard(module)
    return found


GRAPH = {module: _imports(module, path) for module, path in MODULES.items()}


def layer(module: str) -> str:
    if module == "rapid_dsl":
        return "language"   # the package's own __init__ holds only its version
    return next(name for name, prefixes in LAYERS
                if any(module == p or module.startswith(p + ".") for p in prefixes))


def _cycles(graph: dict[str, set[str]]) -> list[list[str]]:
    """Strongly connected components of more than one module (Tarjan's, iterative)."""
    index: dict[str, int] = {}
    low: dict[str, int] = {}
    stack: list[str] = []
    on_stack: set[str] = set()
    out: list[list[str]] = []
    for root in graph:
        if root in index:
            continue
        work = [(root, iter(sorted(graph[root])))]
        index[root] = low[root] = len(index)
        stack.append(root)
        on_stack.add(root)
        while work:
            node, edges = work[-1]
            nxt = next(edges, None)
            if nxt is not None:
                if nxt not in index:
                    index[nxt] = low[nxt] = len(index)
                    stack.append(nxt)
                    on_stack.add(nxt)
                    work.append((nxt, iter(sorted(graph[nxt]))))
                elif nxt in on_stack:
                    low[node] = min(low[node], index[nxt])
                continue
            work.pop()
            if work:
                low[work[-1][0]] = min(low[work[-1][0]], low[node])
            if low[node] == index[node]:
                component = []
                while True:
                    member = stack.pop()
                    on_stack.discard(member)
                    component.append(member)
                    if member == node:
                        break
                if len(component) > 1:
                    out.append(sorted(component))
    return out


def test_the_graph_is_read() -> None:
    assert len(MODULES) > 150
    assert "rapid_dsl.runtime.program" in GRAPH["rapid_dsl.runtime.executor"]


def test_no_import_cycles() -> None:
    assert _cycles(GRAPH) == []


def test_cycles_are_found() -> None:
    assert _cycles({"a": {"b"}, "b": {"c"}, "c": {"a"}, "d": {"a"}}) == [["a", "b", "c"]]


@pytest.mark.parametrize("name", [name for name, _ in LAYERS if name != "services"])
def test_each_layer_imports_only_the_layers_below(name: str) -> None:
    wrong = sorted(f"{m} -> {dep}" for m, deps in GRAPH.items() if layer(m) == name
                   for dep in deps if layer(dep) != name and layer(dep) not in ALLOWED[name])
    assert wrong == []


# The MCP server still runs tools through the command line's entry point; it goes once the
# server calls rapid_dsl.api. A new edge, or this one gone, fails the test until the set is updated.
KNOWN_SERVICE_TO_CLI = {"rapid_dsl.mcp.capture -> rapid_dsl.cli",
                        "rapid_dsl.mcp.tools -> rapid_dsl.cli"}


def test_services_call_the_api_not_the_command_line() -> None:
    wrong = {f"{m} -> {dep}" for m, deps in GRAPH.items() if layer(m) == "services"
             for dep in deps if layer(dep) == "cli"}
    assert wrong == KNOWN_SERVICE_TO_CLI


def test_runtime_top_level_stays_small() -> None:
    top = [p for p in (PACKAGE / "runtime").glob("*.py") if p.name != "__init__.py"]
    assert len(top) <= 30, sorted(p.name for p in top)


def test_every_import_of_the_package_names_something_that_exists() -> None:
    """Imports inside functions run only when their branch does; a moved module or renamed name
    would fail there, at run time, so each one is resolved here."""
    import importlib

    missing = []
    for module, path in MODULES.items():
        for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
            if isinstance(node, ast.ImportFrom) and not node.level \
                    and (node.module or "").startswith("rapid_dsl"):
                target = importlib.import_module(node.module)
                missing += [f"{module}: from {node.module} import {a.name}" for a in node.names
                            if not hasattr(target, a.name)
                            and f"{node.module}.{a.name}" not in MODULES]
            elif isinstance(node, ast.Import):
                for a in node.names:
                    if a.name.startswith("rapid_dsl") and a.name not in MODULES:
                        missing.append(f"{module}: import {a.name}")
    assert missing == []
