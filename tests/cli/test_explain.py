"""`rapidc explain CODE`."""

from __future__ import annotations

import pytest

from rapid_dsl.language.codes import CODES


@pytest.mark.parametrize("code", ["E0302", "e0302", " W0101 ", "E0113"])
def test_known_codes_print_their_title(rapidc, code):
    run = rapidc("explain", code)
    key = code.strip().upper()
    assert (run.code, run.out) == (0, f"{key}: {CODES[key]}\n")


@pytest.mark.parametrize("code", ["E9999", "X", ""])
def test_unknown_codes_are_usage_errors(rapidc, code):
    run = rapidc("explain", code)
    assert run.code == 2
    assert "unknown diagnostic code" in run.err
