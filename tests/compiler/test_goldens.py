"""Generated modules: golden files, what they may import, line markers, determinism, loading.

`pytest --update-goldens` rewrites tests/data/compiled/*.expected.py from the current compiler.
"""

from __future__ import annotations

import ast
import os
import subprocess
import sys
from pathlib import Path

import pytest

from rapid_dsl.compiler import compile_program
from rapid_dsl.frontend.driver import check_file
from rapid_dsl.runtime.loader import LoadError, load

DATA = Path(__file__).resolve().parents[1] / "data" / "compiled"
STDLIB = Path(__file__).resolve().parents[2] / "stdlib_primitives"
# The test programs, and every standard-library primitive (its golden lives in DATA/stdlib).
PROGRAMS = sorted(DATA.glob("*.rapid")) + sorted(STDLIB.glob("*.rapid"))
ROOT = Path(__file__).resolve().parents[2]


def generate(path: Path) -> str:
    result = check_file(str(path))
    assert result.program is not None, [d.message for d in result.diagnostics]
    return compile_program(result.program).source


def expected_path(program: Path) -> Path:
    if program.parent == STDLIB:
        return DATA / "stdlib" / f"{program.stem}.expected.py"
    return program.with_suffix(".expected.py")


@pytest.fixture(scope="module", params=PROGRAMS,
                ids=[f"{p.parent.name}/{p.stem}" for p in PROGRAMS])
def generated(request: pytest.FixtureRequest) -> tuple[Path, str]:
    return request.param, generate(request.param)


def test_there_are_golden_programs():
    assert {p.stem for p in PROGRAMS} >= {"nudge", "align_then_push", "push", "flip", "grasp"}


def test_matches_golden(generated, update_goldens):
    path, source = generated
    expected = expected_path(path)
    if update_goldens:
        expected.write_text(source, encoding="utf-8")
    assert expected.exists(), f"{expected} is missing; run pytest --update-goldens"
    assert source == expected.read_text(encoding="utf-8"), \
        f"{expected.name} differs; review the diff and run pytest --update-goldens"


def test_imports_only_the_runtime_and_names_no_python_builtins(generated):
    _, source = generated
    tree = ast.parse(source)
    for node in ast.walk(tree):
        if isinstance(node, ast.Import):
            assert all(a.name.startswith("rapid_dsl.runtime") for a in node.names), ast.dump(node)
        if isinstance(node, ast.ImportFrom):
            assert node.module is not None and node.module.startswith("rapid_dsl.runtime")
            assert node.level == 0
    defined = {n.id for n in ast.walk(tree) if isinstance(n, ast.Name)
               and isinstance(n.ctx, ast.Store)}
    defined |= {n.name for n in ast.walk(tree) if isinstance(n, ast.FunctionDef)}
    defined |= {a.arg for n in ast.walk(tree) if isinstance(n, ast.FunctionDef)
                for a in n.args.args}
    defined |= {a.asname or a.name for n in ast.walk(tree)
                if isinstance(n, ast.Import | ast.ImportFrom) for a in n.names}
    loaded = {n.id for n in ast.walk(tree) if isinstance(n, ast.Name)
              and isinstance(n.ctx, ast.Load)}
    assert loaded <= defined, f"names from outside the module: {sorted(loaded - defined)}"


def test_builtins_are_reached_only_through_the_registry(generated):
    from rapid_dsl.language.registry import BUILTINS

    _, source = generated
    for node in ast.walk(ast.parse(source)):
        if isinstance(node, ast.Attribute) and isinstance(node.value, ast.Name) \
                and node.value.id in ("B", "Y"):
            assert node.attr in BUILTINS, node.attr


def test_compiles_and_line_markers_point_into_the_sources(generated):
    path, source = generated
    compile(source, f"<rapid {path.stem}>", "exec")
    module = compile_program(check_file(str(path)).program)
    assert module.line_map.entries, "no line markers"
    sources = load(source, path.stem).sources
    for generated_line, marked, line in module.line_map.entries:
        assert source.splitlines()[generated_line - 1].strip() == \
            f"# SOURCES[{sources.index(marked)}]:{line}"
        file = STDLIB / marked.split("/", 1)[1] if marked.startswith("<stdlib>/") \
            else path.parent / marked
        lines = file.read_text(encoding="utf-8").splitlines()
        assert 1 <= line <= len(lines) and lines[line - 1].strip(), (marked, line)
    assert module.line_map.lookup(module.line_map.entries[0][0] + 1)[0] == \
        module.line_map.entries[0][1]


def test_loads_in_the_restricted_namespace(generated):
    path, source = generated
    loaded = load(source, path.stem)
    declared = {p.name for p in loaded.program.primitives} | \
        {s.name for s in loaded.program.strategies}
    assert set(loaded.program.own) & declared


@pytest.mark.slow
def test_the_same_bytes_whatever_the_hash_seed():
    outputs = []
    for seed in ("0", "1"):
        env = {**os.environ, "PYTHONHASHSEED": seed}
        done = subprocess.run(
            [sys.executable, "-m", "rapid_dsl", "compile", str(DATA / "align_then_push.rapid"),
             "-o", "-"], capture_output=True, env=env, cwd=ROOT, check=True)
        outputs.append(done.stdout)
    assert outputs[0] == outputs[1]
    assert outputs[0].decode() == generate(DATA / "align_then_push.rapid")


def test_loader_refuses_other_imports_and_python_builtins():
    with pytest.raises(LoadError, match="line 1: `import os` is not one of the runtime's header"):
        load("import os\n", "evil")
    with pytest.raises(LoadError, match="`open` is not defined in the module"):
        load("open('/etc/passwd')\n", "evil")
    with pytest.raises(LoadError, match="defines no PROGRAM"):
        load("from rapid_dsl.runtime import program as RT\n", "empty")
