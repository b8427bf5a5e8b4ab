"""Reading untrusted JSON: the one strict reader of every JSON file rapidc takes in.

Verify reports and journals, the benchmark's results and journal, tracks and RGB-D frame files
are read with `loads` and checked against pydantic models with `validate`. What `json.loads`
alone would let through, and what each refusal guards against:

- nesting deeper than `MAX_DEPTH`, found by a scan of the brackets before the parser recurses
  (100,000 brackets would otherwise end in a RecursionError);
- integers of more than `MAX_INT_DIGITS` digits (a 401-digit one overflows when a float is made
  of it), `NaN`, `Infinity` and literals such as `1e400` that overflow to infinity;
- a key given twice in one object (the parser would keep the last one silently).

Every problem is a `JsonProblem`: the file, line and column, the JSON path of the value
(`$.results[3].success`) and what is wrong, quoting no more of the input than a key.
"""

from __future__ import annotations

import itertools
import json
import math
import re
from collections.abc import Iterable, Sequence
from dataclasses import dataclass
from typing import Any, TypeVar

from pydantic import BaseModel, ValidationError

MAX_DEPTH = 64            # nested arrays and objects; rapidc's own files nest at most 8 deep
MAX_INT_DIGITS = 30       # a 64-bit integer has 20 digits
MAX_SHOWN_PROBLEMS = 20   # problems listed in one error; the rest are counted
MAX_KEY = 64              # characters of a key quoted in a path or a message

Loc = tuple[str | int, ...]
Model = TypeVar("Model", bound=BaseModel)


@dataclass(frozen=True, slots=True)
class JsonProblem:
    file: str
    path: str                  # JSON path, `$.frames[3].t`; "" for the text as a whole
    message: str
    line: int | None = None    # 1-based, when read from text
    column: int | None = None
    loc: Loc = ()              # the path as keys and indices

    def place(self) -> str:
        if self.line is None:
            return self.file
        return f"{self.file}:{self.line}" + (f":{self.column}" if self.column else "")

    def __str__(self) -> str:
        return f"{self.place()}: {self.path + ': ' if self.path else ''}{self.message}"

    def labelled(self) -> str:
        """As a compiler diagnostic: `file:line:col: error: $.path: message`."""
        return f"{self.place()}: error: {self.path + ': ' if self.path else ''}{self.message}"


class JsonError(ValueError):
    """JSON that cannot be read or does not fit its model; `problems` says where and why."""

    def __init__(self, problems: Sequence[JsonProblem], more: int = 0) -> None:
        self.problems = list(problems)
        self.more = more            # problems found beyond those listed
        lines = [str(p) for p in self.problems]
        if more:
            lines.append(f"... and {more} more problems")
        super().__init__("\n".join(lines))

    def first(self) -> str:
        """The first problem on one line, with a count of the others."""
        others = len(self.problems) - 1 + self.more
        return str(self.problems[0]) + (f" (and {others} more problems)" if others else "")


# --- parsing -----------------------------------------------------------------------------------

_STRING = r'"[^"\\]*(?:\\.[^"\\]*)*"'
_STRINGS = re.compile(_STRING, re.S)
_NOT_BRACKET = re.compile(r"[^\[\]{}]+")
_STEP = {"[": 1, "{": 1, "]": -1, "}": -1}


class _Refused(Exception):
    def __init__(self, message: str, literal: str, key: bool = False) -> None:
        self.message, self.literal, self.key = message, literal, key


def _integer(literal: str) -> int:
    if len(literal.lstrip("-")) > MAX_INT_DIGITS:
        raise _Refused(f"a number has too many digits (an integer of more than "
                       f"{MAX_INT_DIGITS})", literal)
    return int(literal)


def _float(literal: str) -> float:
    value = float(literal)
    if not math.isfinite(value):
        raise _Refused("a number too large to be finite (beyond 1.8e308)", literal)
    return value


def _constant(literal: str) -> float:
    raise _Refused(f"`{literal}` is not a finite number", literal)


def _pairs(items: list[tuple[str, Any]]) -> dict[str, Any]:
    out: dict[str, Any] = {}
    for key, value in items:
        if key in out:
            raise _Refused(f"`{_shown(key)}` is given twice", json.dumps(key), key=True)
        out[key] = value
    return out


def depth(text: str) -> int:
    """How deeply the arrays and objects of `text` nest (brackets inside strings do not count);
    found without recursion, so any depth is measured."""
    brackets = _NOT_BRACKET.sub("", _STRINGS.sub("", text))
    return max(itertools.accumulate(map(_STEP.__getitem__, brackets), initial=0))


def loads(text: str, file: str = "<json>", *, line: int = 1) -> Any:
    """The JSON value of `text`, refused (JsonError) beyond the limits above. `line`: where
    `text` starts in its file (a journal's lines are parsed one by one)."""
    if depth(text) > MAX_DEPTH:
        raise JsonError([JsonProblem(file, "", f"nested too deeply (more than {MAX_DEPTH} "
                                               "arrays and objects)", line, 1)])
    try:
        value = json.loads(text, parse_int=_integer, parse_float=_float,
                           parse_constant=_constant, object_pairs_hook=_pairs)
    except json.JSONDecodeError as exc:
        raise JsonError([JsonProblem(file, "", f"not JSON: {exc.msg}", line + exc.lineno - 1,
                                     exc.colno)]) from None
    except _Refused as exc:
        where, column = _find(text, exc.literal, second=exc.key)
        raise JsonError([JsonProblem(file, "", exc.message, line + where - 1, column)]) \
            from None
    except RecursionError:   # not reached below MAX_DEPTH; kept so no traceback can escape
        raise JsonError([JsonProblem(file, "", "nested too deeply", line, 1)]) from None
    if _SURROGATE_ESCAPE.search(text):
        found = _lone_surrogate(value)
        if found is not None:
            raise problems(file, [found], text=text, line=line)
    return value


_SURROGATE_ESCAPE = re.compile(r"\\u[dD][89a-fA-F]")


def _lone_surrogate(value: Any) -> tuple[Loc, str] | None:
    """The path of the first string (or key) holding an unpaired surrogate, which no file can
    be written with, and the message; walked without recursion."""
    stack: list[tuple[Loc, Any]] = [((), value)]
    while stack:
        loc, item = stack.pop()
        if isinstance(item, str):
            if any(0xD800 <= ord(c) <= 0xDFFF for c in item):
                return loc, LONE_SURROGATE
        elif isinstance(item, dict):
            for key, member in item.items():
                if any(0xD800 <= ord(c) <= 0xDFFF for c in key):
                    return loc, f"a key is {LONE_SURROGATE}"
                stack.append(((*loc, key), member))
        elif isinstance(item, list):
            stack.extend(((*loc, i), member) for i, member in enumerate(item))
    return None


def _find(text: str, literal: str, *, second: bool = False) -> tuple[int, int]:
    """Line and column of `literal` outside strings (a key: its second occurrence as a key)."""
    token = re.compile(_STRING + r"|[^\s{}\[\]:,\"]+")
    seen = 0
    for match in token.finditer(text):
        if match.group() != literal:
            continue
        if literal.startswith('"') and not re.match(r"\s*:", text[match.end():]):
            continue
        seen += 1
        if seen == (2 if second else 1):
            return _position(text, match.start())
    return 1, 1


def _position(text: str, offset: int) -> tuple[int, int]:
    line = text.count("\n", 0, offset) + 1
    return line, offset - (text.rfind("\n", 0, offset) + 1) + 1


def _quoted(key: str) -> str:
    return json.dumps(key[:MAX_KEY]) + ("..." if len(key) > MAX_KEY else "")


def _shown(key: str) -> str:
    """A key as a message quotes it: printable, at most MAX_KEY characters."""
    text = "".join(c if c.isprintable() else c.encode("unicode_escape").decode("ascii")
                   for c in key[:MAX_KEY])
    return text + ("..." if len(key) > MAX_KEY else "")


# --- validating --------------------------------------------------------------------------------

def validate(model: type[Model], data: Any, file: str = "<json>", *, text: str | None = None,
             line: int | None = None) -> Model:
    """`data` (from `loads`) as `model`; raises JsonError naming the JSON path of each problem,
    located in `text` when it is given (else at `line`)."""
    try:
        return model.model_validate(data)
    except ValidationError as error:
        found = [problem_of(tuple(e["loc"]), e["type"], e["msg"]) for e in error.errors()]
    raise problems(file, found, text=text, line=line)


def problems(file: str, found: Sequence[tuple[Loc, str]], *, text: str | None = None,
             line: int | None = None) -> JsonError:
    """A JsonError of (location, message) pairs: located in `text` when it is given (which
    starts at `line` of its file), else at `line` alone (None: no place)."""
    shown = found[:MAX_SHOWN_PROBLEMS]
    if text is None:
        listed = [JsonProblem(file, json_path(loc), message, line, None, loc=loc)
                  for loc, message in shown]
    else:
        places = locate(text, [loc for loc, _ in shown])
        listed = [JsonProblem(file, json_path(loc), message, (line or 1) + places[loc][0] - 1,
                              places[loc][1], loc=loc) for loc, message in shown]
    return JsonError(listed, more=len(found) - len(shown))


LONE_SURROGATE = "not text: it holds a lone surrogate (an unpaired \\ud800-\\udfff escape)"
_MESSAGES = {"missing": "required field is missing", "extra_forbidden": "unknown field",
             "string_unicode": LONE_SURROGATE, "model_type": "Input should be a JSON object",
             "model_attributes_type": "Input should be a JSON object",
             "dict_type": "Input should be a JSON object"}


def problem_of(loc: Loc, kind: str, message: str) -> tuple[Loc, str]:
    """A pydantic error as (location, message): plain words for a few kinds, the path
    without pydantic's own steps (a union's member, a function validator), and a key's own
    problem said of the key."""
    loc = tuple(part for part in loc if not (isinstance(part, str) and (
        part.startswith(("function-", "nullable[", "union[", "list[", "tagged-union["))
        or part in ("int", "float", "str", "bool", "none", "dict", "list", "is-instance"))))
    key = bool(loc) and loc[-1] == "[key]"
    message = _MESSAGES.get(kind, message)
    for prefix in ("Value error, ", "Assertion failed, "):
        message = message.removeprefix(prefix)
    return (loc[:-1], f"the key is {message}") if key else (loc, message)


def json_path(loc: Loc) -> str:
    """`('frames', 3, 'hand')` -> `$.frames[3].hand`; keys that are not plain names quoted."""
    parts = ["$"]
    for part in loc:
        if isinstance(part, int):
            parts.append(f"[{part}]")
        elif re.fullmatch(r"[A-Za-z_][A-Za-z0-9_]*", part) and len(part) <= MAX_KEY:
            parts.append(f".{part}")
        else:
            parts.append(f"[{_quoted(part)}]")
    return "".join(parts)


# --- where a JSON path is in the text ----------------------------------------------------------

_TOKEN = re.compile(r'\s*(?:(' + _STRING + r')|([{}\[\]:,])|([^\s{}\[\]:,"]+))', re.S)


def locate(text: str, locs: Iterable[Loc]) -> dict[Loc, tuple[int, int]]:
    """Line and column (1-based) of the value at each location of valid JSON `text`, or of the
    deepest enclosing value written there (a missing field points at its object); members of an
    object are placed at their key."""
    locs = list(locs)
    wanted = {loc[:n] for loc in locs for n in range(len(loc) + 1)}
    found: dict[Loc, int] = {}
    stack: list[list[Any]] = []    # [kind, path, key or index, expecting a key]
    for match in _TOKEN.finditer(text):
        string, mark, _ = match.groups()
        start = match.start(1) if string else match.start(2) if mark else match.start(3)
        top = stack[-1] if stack else None
        if mark == ",":
            if top is not None and top[0] == "array":
                top[2] += 1
            elif top is not None:
                top[3] = True
            continue
        if mark == ":":
            continue
        if mark in ("}", "]"):
            if stack:
                stack.pop()
            continue
        if top is not None and top[0] == "object" and top[3]:
            top[2], top[3] = json.loads(string) if string else "", False
            path = (*top[1], top[2])
            if path in wanted:
                found[path] = start
            continue
        path = (*top[1], top[2]) if top is not None else ()
        if path in wanted and (top is None or top[0] == "array"):
            found[path] = start
        if mark == "{":
            stack.append(["object", path, None, True])
        elif mark == "[":
            stack.append(["array", path, 0, False])
    places: dict[Loc, tuple[int, int]] = {}
    for loc in locs:
        offset = next((found[loc[:n]] for n in range(len(loc), 0, -1) if loc[:n] in found), 0)
        places[loc] = _position(text, offset)
    return places
