"""Hypothesis strategies for hostile JSON: a real document (a report, a journal's line, a track)
changed the way a tampered or damaged file would be, one change at a time."""

from __future__ import annotations

import copy
import json
from typing import Any

from hypothesis import strategies as st

_MARK = "@@raw@@"
RAW = ["NaN", "Infinity", "-Infinity", "1e400", "-1e999", "9" * 401, "-" + "9" * 31,
       "[" * 100_000, "[" * 50_000 + "]" * 50_000, '{"a":' * 20_000, '"\\ud800"',
       '"\\udfff x"', "1e-400", "0.000000000000000000000000000001"]
PLAIN = st.one_of(
    st.none(), st.booleans(), st.integers(-2**70, 2**70), st.floats(-1e300, 1e300),
    st.text(max_size=6), st.sampled_from(["abc", "/etc/passwd", "../x.rapid", "yes", ""]),
    st.lists(st.integers(0, 3), max_size=3), st.dictionaries(st.text(max_size=3),
                                                             st.integers(), max_size=2))
RAWS = st.sampled_from(RAW).map(lambda raw: (_MARK, raw))
VALUES = st.one_of(PLAIN, RAWS, RAWS)   # raw tokens twice as often: they are what crashes


def _paths(data: Any) -> list[tuple[Any, ...]]:
    """Every path to a value in `data`, the root included."""
    found: list[tuple[Any, ...]] = []
    stack: list[tuple[tuple[Any, ...], Any]] = [((), data)]
    while stack:
        path, item = stack.pop()
        found.append(path)
        if isinstance(item, dict):
            stack.extend(((*path, k), v) for k, v in item.items())
        elif isinstance(item, list):
            stack.extend(((*path, i), v) for i, v in enumerate(item))
    return sorted(found, key=repr)


def _dumps(data: Any, raws: list[str]) -> str:
    text = json.dumps(data)
    for raw in raws:
        text = text.replace(json.dumps(_MARK), raw, 1)
    return text


@st.composite
def changed(draw: st.DrawFn, data: Any) -> str:
    """`data` as JSON text with one hostile change: a value replaced (by another type, a number
    JSON cannot hold finitely, deep nesting, a lone surrogate, ...), a field dropped or added, a
    raw token spliced in, or the text cut short."""
    kind = draw(st.sampled_from(["value"] * 4 + ["drop", "add", "splice", "cut"]))
    data = copy.deepcopy(data)
    raws: list[str] = []
    if kind in ("value", "drop", "add"):
        path = draw(st.sampled_from(_paths(data)))
        parent = data
        for step in path[:-1]:
            parent = parent[step]
        value = draw(VALUES)
        if isinstance(value, tuple):
            raws.append(value[1])
            value = _MARK
        if not path:
            data = value
        elif kind == "drop" and isinstance(parent, dict):
            del parent[path[-1]]
        elif kind == "add" and isinstance(parent, dict):
            parent[draw(st.sampled_from(["extra", path[-1] + "_", "format"]))] = value
        else:
            parent[path[-1]] = value
        return _dumps(data, raws)
    text = json.dumps(data)
    at = draw(st.integers(0, len(text)))
    if kind == "cut":
        return text[:at]
    return text[:at] + draw(st.sampled_from([*RAW, ",", ":", "}", "]", '"', "\\"])) + text[at:]


@st.composite
def changed_lines(draw: st.DrawFn, lines: list[Any], first: int = 0) -> str:
    """JSON lines (a journal) with one of them (from line `first` on, counted from 0) changed,
    or one more line inserted."""
    index = draw(st.integers(first, len(lines)))
    texts = [json.dumps(line, separators=(",", ":")) for line in lines]
    if index == len(lines) or draw(st.booleans()) and index > 0:
        texts.insert(index, draw(changed(lines[min(index, len(lines) - 1)])))
    else:
        texts[index] = draw(changed(lines[index]))
    return "\n".join(texts) + draw(st.sampled_from(["\n", ""]))
