"""`rapidc guide`: the language card is complete (every builtin, every standard primitive), its
example checks and lints clean, and each common error it lists is what the checker reports."""

from __future__ import annotations

import re
from pathlib import Path

import pytest

from rapid_dsl.frontend.card import EXAMPLE, EXAMPLE_PATH, MISTAKES, card
from rapid_dsl.frontend.driver import check_text
from rapid_dsl.language.registry import BUILTINS

STDLIB = Path(__file__).resolve().parents[2] / "stdlib_primitives"


def test_guide_prints_the_card(rapidc):
    run = rapidc("guide")
    assert run.code == 0 and run.err == ""
    assert run.out == card()
    assert run.out.startswith("# The RAPID language card")
    assert len(run.out.splitlines()) < 150    # a screen or two, not a manual


def test_the_card_names_every_builtin_with_its_signature():
    text = card()
    for builtin in BUILTINS.values():
        assert f"`{builtin.signature}`" in text, builtin.name


def test_the_card_names_every_standard_primitive_with_its_params():
    text = card()
    names = sorted(p.stem for p in STDLIB.glob("*.rapid"))
    assert len(names) >= 8
    for name in names:
        assert re.search(rf"^- `{name}\(.*\)` params `", text, re.MULTILINE), name
    assert "`flip(target: Object, support: Surface, fixture: Fixture, hand: Manipulator)` params " \
           "`angle: Angle in [20deg, 120deg] = 90deg`" in text


def test_the_example_checks_and_lints_clean():
    assert check_text(EXAMPLE, EXAMPLE_PATH, lint=True).diagnostics == []


@pytest.mark.parametrize("mistake", MISTAKES, ids=lambda m: f"{m.code}:{m.wrong.strip()[:20]}")
def test_each_common_error_is_the_one_the_checker_reports(mistake):
    wrong = EXAMPLE.replace(mistake.right, mistake.wrong, 1)
    assert wrong != EXAMPLE
    errors = [d for d in check_text(wrong, EXAMPLE_PATH).diagnostics if d.is_error]
    assert errors and errors[0].code == mistake.code
    assert f"- {mistake.code} {errors[0].message}: " in card()


def test_docs_agents_md_shows_the_card(update_goldens: bool) -> None:
    page = Path(__file__).resolve().parents[2] / "docs" / "agents.md"
    begin, end = "<!-- card:begin -->\n", "<!-- card:end -->"
    text = page.read_text(encoding="utf-8")
    generated = f"````markdown\n{card()}````\n"
    start, stop = text.index(begin) + len(begin), text.index(end)
    if update_goldens:
        page.write_text(text[:start] + generated + text[stop:], encoding="utf-8")
        text = page.read_text(encoding="utf-8")
        start, stop = text.index(begin) + len(begin), text.index(end)
    assert text[start:stop] == generated, "docs/agents.md: run pytest --update-goldens"
