"""Every keyword of the grammar reaches every place that lists the language: the highlighter (which
reads them from the grammar), the language card agents read, and the YAML form's schema."""

from __future__ import annotations

import json
import re

import pytest

from rapid_dsl.frontend.card import card
from rapid_dsl.frontend.highlight import KEYWORDS
from rapid_dsl.frontend.yaml import json_schema

# Keywords that live inside expressions, which the YAML form writes as `.rapid` text.
EXPRESSION_WORDS = {"and", "or", "not", "if", "then", "else"}
# Where the YAML form spells a block keyword as a list or a field of another name.
YAML_SPELLING = {"keypoint": "keypoints", "phase": "phases", "in": "range"}


CARD = card()
SCHEMA = json.dumps(json_schema())
SCHEMA_KEYS = set(re.findall(r'"([a-z_]+)"\s*:', SCHEMA))


def test_the_grammar_has_keywords() -> None:
    assert {"primitive", "strategy", "roll", "retry", "on_fail"} <= set(KEYWORDS)


@pytest.mark.parametrize("keyword", KEYWORDS)
def test_every_keyword_is_on_the_card(keyword: str) -> None:
    assert re.search(rf"\b{keyword}\b", CARD)


@pytest.mark.parametrize("keyword", [k for k in KEYWORDS if k not in EXPRESSION_WORDS])
def test_every_block_and_option_keyword_is_in_the_yaml_schema(keyword: str) -> None:
    assert YAML_SPELLING.get(keyword, keyword) in SCHEMA_KEYS or f'"{keyword}"' in SCHEMA
