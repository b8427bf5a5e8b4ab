"""Program text and file names reach generated code only as string literals (regressions).

Each case once ran as Python or broke the module: a comment in a multi-line `requires` clause was
copied into a docstring (`.rapid` and YAML block scalars), the root file's name went into comments
and docstrings, `\\x` or `\\N{` in a clause comment made the module invalid, a lone surrogate
in a YAML goal could not be written out, and a program nested as the checker allows made
a module Python could not parse.
"""

from __future__ import annotations

import ast
import json
from pathlib import Path

import pytest

from rapid_dsl.frontend.parser import MAX_DEPTH
from rapid_dsl.runtime.loader import load

ROOT = Path(__file__).resolve().parents[2]
SCENE = ROOT / "examples" / "scenes" / "push_box.yaml"


def payload(marker: Path) -> str:
    """A comment that closes a docstring and runs a shell command, if copied into one."""
    return (f'# """; from rapid_dsl.runtime.render import os as o; '
            f'o.system("touch {marker}") ; """')


def primitive(comment: str, goal: str = "g") -> str:
    return f"""primitive p {{
  goal {json.dumps(goal)}
  roles {{ b: Object, s: Surface, h: Manipulator }}
  requires {{
    on(b, s) and {comment}
      reachable(h, b)
  }}
  success {{ on(b, s) }}
  cost final = 0
  motion {{ keypoint k = pos(b) + 5cm * up }}
}}
"""


def yaml_primitive(comment: str, goal: str = "g") -> str:
    """The YAML form, the clause as a block scalar; `goal` double-quoted with JSON escapes."""
    return f"""- primitive: p
  goal: {json.dumps(goal)}
  roles: {{b: Object, s: Surface, h: Manipulator}}
  requires:
    - |
      on(b, s) and {comment}
        reachable(h, b)
  success: ["on(b, s)"]
  cost: {{final: "0"}}
  motion: {{keypoints: [{{name: k, at: "pos(b) + 5cm * up"}}]}}
"""


def compiled(rapidc, path: Path) -> str:
    """`rapidc compile PATH -o -`: exit 0, a module of ASCII text that parses."""
    done = rapidc("compile", path, "-o", "-")
    assert done.code == 0, done.err
    assert done.out.isascii()
    ast.parse(done.out)
    return done.out


@pytest.mark.parametrize("form", ["rapid", "yaml"])
def test_a_comment_in_a_requires_clause_stays_data(form, rapidc, tmp_path):
    marker = tmp_path / "pwned"
    text = (primitive if form == "rapid" else yaml_primitive)(payload(marker))
    path = tmp_path / ("p.rapid" if form == "rapid" else "p.rapid.yaml")
    path.write_text(text, encoding="utf-8")

    source = compiled(rapidc, path)
    requirement = load(source, "p").program.primitive("p").requires[0]
    assert payload(marker) in requirement.text
    assert '"""' not in "".join(line for line in source.splitlines()
                                if line.lstrip().startswith("#"))
    # `rapidc run` binds the roles, which evaluates the requirement.
    done = rapidc("run", path, "--scene", SCENE, "--samples", "2", "--iterations", "1",
                  "--quiet")
    assert done.code == 0, done.err
    assert not marker.exists()


@pytest.mark.parametrize("name", [
    'a"""b.rapid',
    "new\nline.rapid",
    "cr\rreturn.rapid",
    """q'uo"te.rapid""",
    "back\\slash\\N{x}\\x.rapid",
    '"""\nimport os; os.system("touch pwned") #.rapid',
    "{{ jinja }}{% if %}{#.rapid",
    "# SOURCES[0]:1.rapid",
])
def test_a_file_name_stays_data(name, rapidc, tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    path = tmp_path / name
    path.write_text(primitive("# c"), encoding="utf-8")

    assert rapidc("check", path).code == 0
    source = compiled(rapidc, path)
    loaded = load(source, "p")
    assert loaded.sources == (name,)
    assert loaded.program.path == name
    assert loaded.program.primitive("p").origin == f"{name}:1"
    comments = [line.strip() for line in source.splitlines() if line.lstrip().startswith("#")]
    assert all(name not in c for c in comments)
    assert not (tmp_path / "pwned").exists()


@pytest.mark.parametrize("comment", [r"# \x", r"# \N{", r"# \N{LATIN SMALL LETTER A} \u12 \U1",
                                     '# \\ \\\\ " """ \'\'\' \\"', "# \x00 NUL \x1b[31m \u202e"])
@pytest.mark.parametrize("form", ["rapid", "yaml"])
def test_escapes_in_a_clause_comment_make_a_valid_module(comment, form, rapidc, tmp_path):
    if form == "yaml" and "\x00" in comment:
        pytest.skip("YAML does not allow NUL or escape characters in a block scalar")
    text = (primitive if form == "rapid" else yaml_primitive)(comment)
    path = tmp_path / ("p.rapid" if form == "rapid" else "p.rapid.yaml")
    path.write_text(text, encoding="utf-8", newline="")

    assert rapidc("check", path).code == 0
    requirement = load(compiled(rapidc, path), "p").program.primitive("p").requires[0]
    assert comment in requirement.text


def test_a_lone_surrogate_in_a_yaml_goal_is_refused_and_a_pair_compiles(rapidc, tmp_path):
    """No UTF-8 text holds a lone surrogate, so the YAML form refuses one (E0115) where `.rapid`
    text could not hold it either; an escaped pair is the one character it stands for."""
    path = tmp_path / "p.rapid.yaml"
    path.write_text(yaml_primitive("# c", goal="g \ud800 end"), encoding="utf-8")
    for argv in (("check", path), ("fmt", path), ("compile", path, "-o", tmp_path / "out")):
        run = rapidc(*argv)
        assert run.code == 1 and "E0115" in run.out + run.err, argv
    assert not (tmp_path / "out").exists()

    path.write_text(yaml_primitive("# c", goal="g \ud83d\ude00 end"), encoding="utf-8")
    assert rapidc("check", path).code == 0
    done = rapidc("compile", path, "-o", tmp_path / "out")
    assert done.code == 0, done.err
    written = (tmp_path / "out" / "p.py").read_text(encoding="ascii")
    assert load(written, "p").program.primitive("p").goal == "g \U0001f600 end"


def test_names_starting_with_two_underscores_are_renamed_in_code(rapidc, tmp_path):
    path = tmp_path / "d.rapid"
    path.write_text("""def __init__(__class__: Body) -> Length = height(__class__)
primitive __import__ {
  goal "g"
  roles { __class__: Object, s: Surface, h: Manipulator }
  params { __globals__: Length = 1cm }
  resolve { __dict__ = __init__(__class__) + __globals__ }
  success { on(__class__, s) }
  cost final = __dict__ / 1cm
  motion { keypoint __code__ = pos(__class__) }
}
""", encoding="utf-8")
    source = compiled(rapidc, path)
    primitive_ = load(source, "d").program.primitive("__import__")
    assert [r.name for r in primitive_.roles] == ["__class__", "s", "h"]
    assert primitive_.params[0].name == "__globals__"
    names = {n.id for n in ast.walk(ast.parse(source)) if isinstance(n, ast.Name)}
    assert "U__class__" in names and not any(n.startswith("__") for n in names)


def test_a_folded_constant_shows_its_source_form_beside_it(rapidc, tmp_path):
    path = tmp_path / "p.rapid"
    cost = "cost final = abs(yaw(b) - 15deg) / 1deg + height(b) / 2mm"
    path.write_text(primitive("# c").replace("cost final = 0", cost), encoding="utf-8")
    source = compiled(rapidc, path)
    assert "return B.abs(F, B.yaw(F, b) - 0.2617993877991494) / 0.017453292519943295 + " \
        "B.height(F, b) / 0.002  # 15deg, 1deg, 2mm" in source
    assert "RT.scale(0.05, B.up)  # 5cm" in source


@pytest.mark.slow
def test_a_program_nested_as_deeply_as_the_checker_allows_loads(rapidc, tmp_path):
    """Python's parser takes at most 200 nested brackets: deeper parts go into temporaries."""
    n = MAX_DEPTH - 10
    chain = " and ".join(["on(b, s)"] * n)
    minus = "-" * n
    path = tmp_path / "deep.rapid"
    path.write_text(f"""def f(b: Body) -> Length = {minus}height(b)
primitive p {{
  goal "g"
  roles {{ b: Object, s: Surface, h: Manipulator }}
  requires {{ {chain} }}
  params {{ d: Length = 1cm }}
  success {{
    {chain}
    {minus}f(b) < {minus}1cm
  }}
  cost final = 0
  motion {{ keypoint k = pos(b) + 5cm * up  yaw {minus}yaw(b) }}
}}
strategy t {{
  goal "g"
  roles {{ x: Object, y: Surface, z: Manipulator }}
  phase one: p(b=x, s=y, h=z) {{
    d = solve v: Length minimize {"-" * 150}(v / 1cm) subject {{ {minus}v <= height(x) }}
  }}
}}
""", encoding="utf-8")
    assert rapidc("check", path).code == 0
    source = compiled(rapidc, path)
    assert "    T1 = " in source
    assert len(load(source, "deep").program.primitive("p").success.clauses) == 2
