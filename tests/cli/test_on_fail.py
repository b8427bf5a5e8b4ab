"""`phase ... on_fail continue`: parsed, checked, formatted, in the YAML form and compiled.

A strategy stops at its first failed phase; going on is written in the program (tests/runtime/
test_verdicts.py runs it).
"""

from __future__ import annotations

from rapid_dsl.compiler import compile_program
from rapid_dsl.frontend.driver import check_file

HEAD = """use stdlib.push

strategy s {
  goal "Push twice"
  roles { box: Object, table: Surface, hand: Manipulator }
"""
ONE_LINE = HEAD + """  phase a: push(target=box, support=table, hand=hand) { displacement = [1cm, 0cm, 0cm] } on_fail continue
  phase b: push(target=box, support=table, hand=hand) { displacement = [1cm, 0cm, 0cm] } on_fail stop
}
"""  # noqa: E501 - the formatter breaks the first phase, which is too long for one line


def test_on_fail_is_checked_and_compiled_only_where_it_continues(write):
    path = write("s.rapid", ONE_LINE)
    result = check_file(str(path))
    assert result.diagnostics == [] and result.program is not None
    phases = result.program.strategy("s").phases
    assert [p.on_fail for p in phases] == ["continue", "stop"]
    source = compile_program(result.program).source
    assert source.count('on_fail="continue"') == 1 and 'on_fail="stop"' not in source


def test_an_unknown_on_fail_value_is_an_error_at_the_value(rapidc, write):
    path = write("s.rapid", HEAD + "  phase a: push(target=box, support=table, hand=hand) {\n"
                 "    displacement = [1cm, 0cm, 0cm]\n  } on_fail retry\n}\n")
    run = rapidc("check", path)
    assert run.code == 1
    assert "s.rapid:8:13: error[E0406]: `on_fail` takes `stop` or `continue`, not `retry`" \
        in run.out + run.err


def test_fmt_keeps_on_fail_on_one_line_and_after_a_block(rapidc, write):
    path = write("s.rapid", ONE_LINE)
    run = rapidc("fmt", path)
    assert run.code == 0, run.err
    assert ("  phase a: push(target=box, support=table, hand=hand) {\n"
            "    displacement = [1cm, 0cm, 0cm]\n  } on_fail continue\n") in run.out
    again = write("t.rapid", run.out)
    assert rapidc("fmt", "--check", again).code == 0
    short = write("u.rapid", HEAD + "  phase a: push(target=box, support=table, hand=hand) "
                  "on_fail continue\n}\n")
    assert "  phase a: push(target=box, support=table, hand=hand) on_fail continue\n" \
        in rapidc("fmt", short).out


def test_on_fail_in_the_yaml_form(rapidc, write):
    path = write("s.rapid.yaml", """- use: stdlib.push
- strategy: s
  goal: Push twice
  roles: {box: Object, table: Surface, hand: Manipulator}
  phases:
    - name: a
      primitive: push
      roles: {target: box, support: table, hand: hand}
      args: {displacement: "[1cm, 0cm, 0cm]"}
      on_fail: continue
""")
    result = check_file(str(path))
    assert result.diagnostics == [] and result.program is not None
    assert result.program.strategy("s").phases[0].on_fail == "continue"
    assert "} on_fail continue" in rapidc("fmt", path).out
