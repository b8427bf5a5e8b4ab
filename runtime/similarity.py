"""How well a scene entity's name and label match a role name or a user's hint (binding rank).

Texts are split into lowercase words: at anything that is not a letter or digit, at lower-to-upper
case changes and between letters and digits (`crate_2`, `redCrate`, `crate2` -> `crate`, `2` /
`red`, `crate`); a few filler words (`the`, `a`, ...) are dropped. Two words match with their
difflib ratio when it is at least `WORD_MATCH` (`box`/`boxes` 0.75, `wall`/`walls` 0.89), else 0.
A query's similarity to a text is the mean, over the query's words, of each word's best match in
the text; to an entity, the better of its name and its label. A role's score for an entity is the
similarity of the role's name plus `HINT_WEIGHT` times that of its `--hint` text, rounded to 3
decimals so that equal matches tie exactly.
"""

from __future__ import annotations

import re
from difflib import SequenceMatcher
from functools import lru_cache

WORD_MATCH = 0.75
# A hint is the user's own words: its match decides, the role name's only breaks its ties.
HINT_WEIGHT = 10.0
FILLER = frozenset({"a", "an", "the", "of", "on", "in", "at", "to", "with", "and"})

_WORD = re.compile(r"[A-Z]+(?![a-z])|[A-Z]?[a-z]+|[0-9]+")


@lru_cache(maxsize=4096)
def words(text: str) -> tuple[str, ...]:
    """`"the redCrate_2"` -> `("red", "crate", "2")`."""
    return tuple(w for w in (m.lower() for m in _WORD.findall(text)) if w not in FILLER)


@lru_cache(maxsize=65536)
def _match(a: str, b: str) -> float:
    ratio = SequenceMatcher(None, a, b).ratio()
    return ratio if ratio >= WORD_MATCH else 0.0


def similarity(query: str, text: str) -> float:
    """Mean over the query's words of their best match among the text's words, in [0, 1]."""
    asked, given = words(query), words(text)
    if not asked or not given:
        return 0.0
    return sum(max(_match(a, g) for g in given) for a in asked) / len(asked)


def role_score(role: str, hint: str | None, name: str, label: str) -> float:
    """The rank score of entity (`name`, `label`) for a role, with the role's hint if given."""
    def best(query: str) -> float:
        return max(similarity(query, name), similarity(query, label))

    score = best(role) + (HINT_WEIGHT * best(hint) if hint else 0.0)
    return round(score, 3)
