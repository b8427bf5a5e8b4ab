"""The YAML form: the same AST as `.rapid`, diagnostics at YAML lines, never a crash, the schema."""

from __future__ import annotations

import json
from pathlib import Path

import pytest
from jsonschema import Draft202012Validator
from ruamel.yaml import YAML

from rapid_dsl.frontend.parser import parse_module
from rapid_dsl.frontend.yaml import CODES, SCHEMA_ID, json_schema, parse_yaml_module

DATA = Path(__file__).resolve().parents[1] / "data"
PAIRS = [("fmt/yaml_flip.rapid.yaml", "language/flip.rapid"),
         ("yaml/flip_and_grasp.rapid.yaml", "language/flip_and_grasp.rapid"),
         ("yaml/solve.rapid.yaml", "language/solve.rapid"),
         ("yaml/declarations.rapid.yaml", "language/declarations.rapid")]

PRIMITIVE = """\
- primitive: reach_it
  goal: Touch the target
  roles: {target: Object, hand: Manipulator}
  success:
    - touching(hand, target)
  cost:
    final: distance(hand, target) / 1cm
  motion:
    keypoints:
      - {name: reach, at: pos(target)}
"""


def parse(text: str) -> tuple[object, list[tuple[int, int, str, str]]]:
    module, diagnostics = parse_yaml_module(text, "p.rapid.yaml")
    return module, [(d.span.line, d.span.col, d.code, d.message) for d in diagnostics]


@pytest.mark.parametrize(("yaml_file", "rapid_file"), PAIRS, ids=[p[0] for p in PAIRS])
def test_yaml_gives_the_same_ast_as_rapid(yaml_file, rapid_file):
    module, diagnostics = parse_yaml_module((DATA / yaml_file).read_text(), "x")
    expected, _ = parse_module((DATA / rapid_file).read_text(), "x")
    assert diagnostics == []
    assert module == expected


def test_yaml_programs_check_clean(rapidc):
    assert rapidc("check", DATA / "yaml").code == 0


def test_empty_file_is_an_empty_program():
    for text in ("", "# only a comment\n", "---\n"):
        module, diagnostics = parse(text)
        assert diagnostics == [] and module.decls == ()


def test_expression_errors_point_at_yaml_lines_and_columns():
    text = PRIMITIVE.replace("    - touching(hand, target)", '    - "gap <"\n    - 3qq < 1')
    module, diagnostics = parse(text)
    assert module is None
    assert diagnostics == [
        (5, 13, "E0103", "unexpected end of file; expected an expression"),
        (6, 7, "E0105", "unknown unit `qq` in `3qq`"),
    ]


def test_type_errors_from_the_checker_point_at_yaml_lines(rapidc, write):
    path = write("p.rapid.yaml", PRIMITIVE.replace("final: distance(hand, target) / 1cm",
                                                   'final: "distance(hand, target) + 1deg"'))
    run = rapidc("check", "--format", "json", path)
    assert run.code == 1
    [found] = json.loads(run.out)
    assert (found["line"], found["column"], found["code"]) == (7, 13, "E0301")


def test_block_scalars_start_on_their_first_content_line():
    text = PRIMITIVE.replace("    - touching(hand, target)", "    - |\n      touching(hand, 3qq)")
    _, diagnostics = parse(text)
    assert diagnostics == [(6, 22, "E0105", "unknown unit `qq` in `3qq`")]


def test_unquoted_commas_in_flow_lists_get_a_hint():
    text = PRIMITIVE.replace("  success:\n    - touching(hand, target)",
                             "  success: [touching(hand, target)]")
    module, diagnostics = parse_yaml_module(text, "p")
    assert module is None
    assert "put the expression in quotes" in diagnostics[0].help


@pytest.mark.parametrize(("change", "expected"), [
    (("  goal: Touch", "  gaol: Touch"),
     [(1, 3, "E0111", "missing `goal` in primitive `reach_it`"),
      (2, 3, "E0111", "unknown key `gaol` in primitive `reach_it`")]),
    (("{name: reach, at: pos(target)}", "{name: reach, at: pos(target), gripper: half}"),
     [(10, 49, "E0111", "`half` is not allowed here")]),
    (("{name: reach, at: pos(target)}", "{name: reach}"),
     [(10, 9, "E0111", "missing `at` in `motion.keypoints[0]` of primitive `reach_it`")]),
    (("roles: {target: Object", "roles: {Target: Object"),
     [(3, 11, "E0114", "`Target` is not a name")]),
    (("primitive: reach_it", "primitive: Reach"),
     [(1, 14, "E0114", "`Reach` is not a name")]),
    (("  success:\n", "  success: yes\n  old_success:\n"),
     [(4, 12, "E0111", "expected a list here, found `yes`"),
      (5, 3, "E0111", "unknown key `old_success` in primitive `reach_it`")]),
    (("  cost:\n", "  roles: {}\n  cost:\n"),
     [(6, 3, "E0113", "`roles` appears twice in this mapping")]),
    (("    final: distance(hand, target) / 1cm", "    weight: 2"),
     [(7, 5, "E0111", "`weight` weighs the progress cost, but there is no `progress`")]),
    (("  goal: Touch the target", "  goal: |\n    Touch\n    the target"),
     [(2, 9, "E0115", "a goal must be one line")]),
])
def test_shape_errors(change, expected):
    old, new = change
    assert old in PRIMITIVE
    module, diagnostics = parse(PRIMITIVE.replace(old, new))
    assert module is None
    assert diagnostics == expected


def test_unknown_keys_get_a_suggestion_or_the_allowed_keys():
    _, diagnostics = parse_yaml_module(PRIMITIVE.replace("  goal:", "  gaol:"), "p")
    assert diagnostics[1].help == "did you mean `goal`?"
    _, diagnostics = parse_yaml_module(PRIMITIVE.replace("    final:", "    zzz:"), "p")
    assert diagnostics[0].help == "allowed here: `final`, `progress`, `weight`"


@pytest.mark.parametrize(("text", "expected"), [
    ("primitive: x\n", [(1, 1, "E0111", ("a YAML program is a list of declarations, "
                                        "found a mapping"))]),
    ("- 3\n- {use: stdlib.push, def: f}\n",
     [(1, 3, "E0112", ("a declaration has exactly one of the keys `use`, `relation`, `def`, "
                      "`primitive`, `strategy`; found `3`")),
      (2, 3, "E0112", ("a declaration has exactly one of the keys `use`, `relation`, `def`, "
                      "`primitive`, `strategy`; this one has `use`, `def`"))]),
    ("- use: push\n", [(1, 8, "E0108", "`use: push` names no declaration")]),
    ("- use: 'stdlib.{a,'\n", [(1, 8, "E0111", "`use: stdlib.{a,` names no declaration")]),
    ("- relation: near\n  params: {a: Body\n", [(3, 1, "E0110", ("invalid YAML: while parsing "
                                                 "a flow mapping: expected ',' or '}', but got "
                                                 "'<stream end>'"))]),
    ("- a\n---\n- b\n", [(2, 1, "E0110", ("invalid YAML: expected a single document in the "
                                         "stream: but found another document"))]),
])
def test_document_errors(text, expected):
    module, diagnostics = parse(text)
    assert module is None
    assert diagnostics == expected


@pytest.mark.parametrize("text", [
    "[" * 10_000 + "]" * 10_000,
    "- " * 5000 + "x\n",
    "a: &a [*a]\n",
    "x: &x [a, a, a, a, a, a, a, a, a, a]\n" + "".join(
        f"{chr(98 + i)}: &{chr(98 + i)} [*{chr(97 + i) if i else 'x'}" + ", *"
        f"{chr(97 + i) if i else 'x'}" * 9 + "]\n" for i in range(8)),
    "\t- primitive: x\n",
    "\x00\x01\x02",
    "- {primitive: x, goal: g, roles: [], success: {}, motion: 3}\n",
    "- {strategy: s, goal: g, phases: [{name: p, primitive: q, args: {a: [1]}}]}\n",
], ids=["brackets", "dashes", "self-alias", "alias-bomb", "tab", "control",
        "kinds", "arg-list"])
@pytest.mark.slow
def test_malformed_yaml_gets_diagnostics_not_exceptions(text):
    module, diagnostics = parse_yaml_module(text, "p.rapid.yaml")
    assert module is None
    assert diagnostics and all(d.code.startswith("E01") for d in diagnostics)


def test_a_bad_character_is_reported_where_it_is():
    _, diagnostics = parse("- a\n- b\x01c\n")
    assert diagnostics == [(2, 4, "E0110", ("invalid YAML: unacceptable character #x0001: "
                                           "special characters are not allowed"))]


def test_a_megabyte_goal_is_read():
    text = '- primitive: x\n  goal: "' + "y" * 1_000_000 + '"\n'
    module, diagnostics = parse_yaml_module(text, "p")
    assert diagnostics == []
    assert module.decls[0].blocks[0].text == "y" * 1_000_000


def test_schema_is_valid_json_schema_2020_12(rapidc):
    run = rapidc("schema")
    assert run.code == 0
    schema = json.loads(run.out)
    assert schema == json_schema()
    assert schema["$schema"] == "https://json-schema.org/draft/2020-12/schema"
    assert schema["$id"] == SCHEMA_ID
    Draft202012Validator.check_schema(schema)


@pytest.mark.parametrize("path", sorted(DATA.glob("**/*.rapid.yaml")), ids=lambda p: p.name)
def test_yaml_programs_validate_against_the_schema(path):
    document = YAML(typ="safe").load(path.read_text())
    assert list(Draft202012Validator(json_schema()).iter_errors(document)) == []


@pytest.mark.parametrize("document", [
    {"primitive": "p"},
    [{"primitive": "p", "goal": "g", "gaol": "typo"}],
    [{"primitive": "P", "goal": "g"}],
    [{"strategy": "s", "goal": "g", "phases": [{"name": "a"}]}],
    [{"relation": "r", "body": "x", "params": {"a": 3}}],
    [{"use": "stdlib.push", "def": "f"}],
])
def test_the_schema_rejects_what_the_loader_rejects(document):
    assert list(Draft202012Validator(json_schema()).iter_errors(document))


def test_every_yaml_code_is_documented():
    assert sorted(CODES) == [f"E011{i}" for i in range(7)]
    assert all(CODES.values())


@pytest.mark.slow
def test_reading_stops_at_the_token_limit_where_it_is_reached():
    """A flow list of 100,000 numbers would take ruamel's reader seconds per 100 kB: it is
    refused at the token where the limit falls, before the rest is read."""
    from rapid_dsl.frontend.yaml import MAX_TOKENS

    text = "- strategy: s\n  success: [" + ", ".join(["1"] * MAX_TOKENS) + "]\n"
    _, found = parse(text)
    assert [(line, code) for line, _, code, _ in found] == [(2, "E0116")]
    assert found[0][3] == f"the YAML has more than {MAX_TOKENS} tokens"


def test_a_lone_surrogate_is_refused_and_a_pair_is_one_character(rapidc, tmp_path):
    lone = tmp_path / "lone.rapid.yaml"
    lone.write_text(PRIMITIVE.replace("goal: Touch the target", 'goal: "touch \\ud800"'))
    assert parse(lone.read_text())[1] == [
        (2, 9, "E0115", "this text holds a lone surrogate (U+D800), which UTF-8 text cannot hold")]
    for command in ("check", "fmt", "compile"):
        run = rapidc(command, lone, *(["-o", "-"] if command == "compile" else []))
        assert run.code == 1, (command, run.err)
    pair = tmp_path / "pair.rapid.yaml"
    pair.write_text(PRIMITIVE.replace("goal: Touch the target", 'goal: "touch \\ud83d\\ude00"'))
    module, found = parse(pair.read_text())
    assert found == [] and "touch \U0001f600" in repr(module)
    assert rapidc("fmt", pair).code == 0
