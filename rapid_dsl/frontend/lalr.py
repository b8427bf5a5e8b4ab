"""A small LALR(1) runtime for the tables that lark builds from grammar/rapid.lark.

lark is imported only to build the tables (frontend/parser_tables.py, once per grammar): its
import alone costs more than checking a 200-line file. This module does at run time what lark's
LALR front end does, the same way, so trees and errors are the same (a test parses the corpus and
mutated programs both ways and compares):

- a contextual lexer: in each parser state only the terminals that state accepts (plus the
  ignored ones and `always_accept`), as one regular expression whose alternatives are ordered as
  lark orders them; a keyword that the name terminal also matches is lexed as a name and renamed
  when the state accepts it; where nothing matches, the error names the token the whole grammar
  would see there;
- the shift-reduce loop over the action table, with a post-lexer between lexer and parser;
- tree shapes: anonymous tokens dropped, `_rules` spliced into their parent, `?rules` with one
  child replaced by it, and positions as lark's `propagate_positions` gives them (a node starts
  at its first child's container, so `(x)` spans its parentheses where it is an operand).

Instead of building trees, each reduction calls the builder method of the rule's name (alias or
origin) with the node's `Meta` and its children's values, bottom-up as a tree walk would.
"""

from __future__ import annotations

import re
from collections.abc import Iterable, Iterator
from typing import Any, Protocol

FORMAT = 3      # of the tables (parser_tables.py writes them); bump when their layout changes


class Token(str):
    """A terminal with its place: [start_pos, end_pos), 1-based lines and columns."""

    type: str
    start_pos: int
    end_pos: int
    line: int
    column: int
    end_line: int
    end_column: int

    def __new__(cls, type_: str, value: str, start_pos: int = 0, line: int = 1, column: int = 1,
                end_line: int | None = None, end_column: int | None = None,
                end_pos: int | None = None) -> Token:
        token = super().__new__(cls, value)
        token.type, token.start_pos, token.line, token.column = type_, start_pos, line, column
        token.end_line = line if end_line is None else end_line
        token.end_column = column + len(value) if end_column is None else end_column
        token.end_pos = start_pos + len(value) if end_pos is None else end_pos
        return token

    @property
    def value(self) -> str:
        return str(self)


class Meta:
    """A node's place (`empty` when it has no token) and its container's, which is wider where
    a `?rule` passed the node up through tokens it dropped, such as parentheses."""

    __slots__ = ("empty", "line", "column", "start_pos", "end_line", "end_column", "end_pos",
                 "start", "end")

    def __init__(self) -> None:
        self.empty = True
        self.line: int | None = None
        self.column: int | None = None
        self.start_pos: int | None = None
        self.end_line: int | None = None
        self.end_column: int | None = None
        self.end_pos: int | None = None
        self.start: tuple[int, int, int] | None = None     # container (line, column, pos)
        self.end: tuple[int, int, int] | None = None


class UnexpectedInput(Exception):
    pass


class UnexpectedCharacters(UnexpectedInput):
    """No terminal of the parser's state starts at `pos_in_stream`."""

    def __init__(self, pos: int, line: int, column: int, allowed: set[str]) -> None:
        super().__init__(f"no terminal matches at line {line} column {column}")
        self.pos_in_stream, self.line, self.column, self.allowed = pos, line, column, allowed


class UnexpectedToken(UnexpectedInput):
    """`token` where the parser's state expects one of `expected` (terminal names; for an error
    of the lexer, those its state lexes); `accepts` are those that the parser, after the
    reductions they call for, would really shift (lark's `UnexpectedToken.accepts`)."""

    def __init__(self, token: Token, expected: set[str], accepts: set[str]) -> None:
        super().__init__(f"unexpected {token.type} at line {token.line} column {token.column}")
        self.token, self.expected, self.accepts = token, expected, accepts
        self.line, self.column = token.line, token.column


class PostLexer(Protocol):
    always_accept: tuple[str, ...]

    def process(self, stream: Iterator[Token]) -> Iterator[Token]: ...


class _Entry:
    """A value on the parse stack: a token (its own place), a built node, or the children of a
    `_rule` to splice into its parent (these two with a Meta)."""

    __slots__ = ("value", "meta")

    def __init__(self, value: Any, meta: Meta | Token) -> None:
        self.value, self.meta = value, meta


class _Rule:
    __slots__ = ("name", "origin", "size", "splice", "expand1", "keep")

    def __init__(self, name: str, origin: str, size: int, splice: bool, expand1: bool,
                 keep: list[tuple[int, bool]] | None) -> None:
        self.name, self.origin, self.size = name, origin, size
        self.splice, self.expand1 = splice, expand1
        self.keep = keep     # (child index, splice it) of the children kept; None: all, as is


class _Terminal:
    __slots__ = ("name", "regexp", "literal", "priority", "width", "keywords")

    def __init__(self, name: str, kind: str, pattern: str, priority: int, width: int,
                 keywords: list[str]) -> None:
        self.name, self.priority, self.width = name, priority, width
        self.literal = pattern if kind == "str" else None
        self.regexp = re.escape(pattern) if kind == "str" else pattern
        self.keywords = frozenset(keywords)   # literals of equal priority it matches whole

    def sort_key(self) -> tuple[int, int, int, str]:
        source = self.literal if self.literal is not None else self.regexp
        return (-self.priority, -self.width, -len(source), self.name)


class _Scanner:
    """The lexer of one set of terminals (lark's BasicLexer)."""

    def __init__(self, terminals: list[_Terminal], ignore: frozenset[str]) -> None:
        terminals = sorted(terminals, key=_Terminal.sort_key)
        patterns = [t for t in terminals if t.literal is None]
        literals = [t for t in terminals if t.literal is not None]
        self.keywords: dict[str, dict[str, str]] = {}   # pattern -> {its literal: literal's name}
        embedded: set[str] = set()
        for pattern in patterns:
            found = {t.literal: t.name for t in literals
                     if t.name in pattern.keywords and t.literal is not None}
            if found:
                self.keywords[pattern.name] = found
                embedded.update(found.values())
        kept = [t for t in terminals if t.name not in embedded]
        self.regex = re.compile("|".join(f"(?P<{t.name}>{t.regexp})" for t in kept))
        self.allowed = {t.name for t in kept} - ignore or {"<END-OF-FILE>"}
        self.multiline = frozenset(t.name for t in terminals if _has_newline(t.regexp))
        self.ignore = ignore


def _has_newline(regexp: str) -> bool:
    return "\n" in regexp or "\\n" in regexp or "\\s" in regexp or "[^" in regexp or \
        ("(?s" in regexp and "." in regexp)


class _Lexer:
    """The text and the place reached in it."""

    __slots__ = ("text", "pos", "line", "line_start")

    def __init__(self, text: str) -> None:
        self.text, self.pos, self.line, self.line_start = text, 0, 1, 0

    def next(self, scanner: _Scanner) -> Token | None:
        """The next token that is not ignored, or None at the end of the text."""
        text = self.text
        while self.pos < len(text):
            match = scanner.regex.match(text, self.pos)
            if match is None:
                raise UnexpectedCharacters(self.pos, self.line, self.pos - self.line_start + 1,
                                           scanner.allowed)
            value, kind = match.group(0), match.lastgroup
            assert kind is not None
            start, line, column = self.pos, self.line, self.pos - self.line_start + 1
            if kind in scanner.multiline:
                newlines = value.count("\n")
                if newlines:
                    self.line += newlines
                    self.line_start = start + value.rindex("\n") + 1
            self.pos = start + len(value)
            if kind in scanner.ignore:
                continue
            keywords = scanner.keywords.get(kind)
            if keywords is not None:
                kind = keywords.get(value, kind)
            return Token(kind, value, start, line, column, self.line,
                         self.pos - self.line_start + 1, self.pos)
        return None


class Parser:
    """Parses text with the tables of parser_tables.py (validated here: a damaged table raises
    ValueError now, not some other error in the middle of a parse)."""

    def __init__(self, tables: dict[str, Any], always_accept: Iterable[str] = ()) -> None:
        try:
            self._load(tables, tuple(always_accept))
        except (KeyError, TypeError, IndexError, AssertionError, re.error) as exc:
            raise ValueError(f"damaged parser tables: {exc!r}") from None

    def _load(self, tables: dict[str, Any], always_accept: tuple[str, ...]) -> None:
        assert tables["format"] == FORMAT
        self.terminals = {t["name"]: _Terminal(t["name"], t["kind"], t["pattern"],
                                               int(t["priority"]), int(t["width"]),
                                               [str(k) for k in t["keywords"]])
                          for t in tables["terminals"]}
        assert all(t["kind"] in ("str", "re") for t in tables["terminals"])
        self.ignore = frozenset(tables["ignore"])
        self.always = frozenset(always_accept)
        self.rules = [_Rule(r["name"], r["origin"], int(r["size"]), bool(r["splice"]),
                            bool(r["expand1"]), None if r["keep"] is None else
                            [(int(i), bool(splice)) for i, splice in r["keep"]])
                      for r in tables["rules"]]
        self.states: list[dict[str, tuple[int, int]]] = [
            {symbol: (int(action), int(arg)) for symbol, (action, arg) in state.items()}
            for state in tables["states"]]
        for state in self.states:
            for action, arg in state.values():
                assert action in (0, 1) and 0 <= arg < len(self.rules if action else self.states)
        self.start_states = {k: int(v) for k, v in tables["start_states"].items()}
        self.end_states = {k: int(v) for k, v in tables["end_states"].items()}
        self.literals = {name: t.literal for name, t in self.terminals.items()
                         if t.literal is not None}
        self._scanners: dict[frozenset[str], _Scanner] = {}
        self._by_state: dict[int, _Scanner] = {}
        self._root: _Scanner | None = None

    def scanner(self, state: int) -> _Scanner:
        """The lexer of a parser state, built the first time the state lexes (lazily, as most
        files visit few of the states)."""
        found = self._by_state.get(state)
        if found is None:
            names = frozenset(s for s in self.states[state] if s in self.terminals)
            found = self._scanners.get(names)
            if found is None:
                wanted = names | self.ignore | self.always
                found = self._scanners[names] = _Scanner(
                    [t for n, t in self.terminals.items() if n in wanted], self.ignore)
            self._by_state[state] = found
        return found

    def parse(self, text: str, start: str, builder: Any, postlex: PostLexer) -> Any:
        """The builder's value for the whole text, built bottom-up during the parse. Raises
        UnexpectedCharacters or UnexpectedToken (and whatever the post-lexer raises)."""
        stack = [self.start_states[start]]
        values: list[_Entry] = []
        end_state = self.end_states[start]
        lexer = _Lexer(text)

        def tokens() -> Iterator[Token]:
            while True:
                try:
                    token = lexer.next(self.scanner(stack[-1]))
                except UnexpectedCharacters as problem:
                    # as lark's contextual lexer: name the token the whole grammar sees there
                    found = _recover(lexer, self._root_scanner())
                    if found is None:
                        raise
                    raise UnexpectedToken(found, problem.allowed,
                                          self._accepts(stack, end_state)) from None
                if token is None:
                    return
                yield token

        last: Token | None = None
        for token in postlex.process(tokens()):
            self._feed(token, stack, values, builder, end_state, False)
            last = token
        end = Token("$END", "", last.start_pos, last.line, last.column, last.end_line,
                    last.end_column, last.end_pos) if last is not None else Token("$END", "")
        return self._feed(end, stack, values, builder, end_state, True)

    def _accepts(self, stack: list[int], end_state: int) -> set[str]:
        """The terminals the parser would take in this state after the reductions they call
        for: shift, or for the end of the text, complete the start symbol."""
        return {s for s in self.states[stack[-1]]
                if s.isupper() and self._takes(stack, s, end_state)}

    def _takes(self, stack: list[int], terminal: str, end_state: int) -> bool:
        stack = list(stack)
        while True:
            found = self.states[stack[-1]].get(terminal)
            if found is None:
                return False
            action, arg = found
            if action == 0:
                return True
            rule = self.rules[arg]
            if rule.size:
                del stack[-rule.size:]
            stack.append(self.states[stack[-1]][rule.origin][1])
            if terminal == "$END" and stack[-1] == end_state:
                return True

    def _root_scanner(self) -> _Scanner:
        if self._root is None:
            self._root = _Scanner(list(self.terminals.values()), self.ignore)
        return self._root

    def _feed(self, token: Token, stack: list[int], values: list[_Entry], builder: Any,
              end_state: int, is_end: bool) -> Any:
        """Shift `token` after the reductions it calls for; at the end of the text (`$END`),
        reduce until the start symbol is complete and return its value."""
        states, rules = self.states, self.rules
        while True:
            actions = states[stack[-1]]
            found = actions.get(token.type)
            if found is None:
                raise UnexpectedToken(token, {s for s in actions if s.isupper()},
                                      self._accepts(stack, end_state))
            action, arg = found
            if action == 0:   # shift
                stack.append(arg)
                values.append(_Entry(token, token))
                return None
            rule = rules[arg]
            size = rule.size
            if size:
                children = values[-size:]
                del values[-size:]
                del stack[-size:]
            else:
                children = []
            values.append(_reduce(rule, children, builder))
            stack.append(states[stack[-1]][rule.origin][1])
            if is_end and stack[-1] == end_state:
                return values[-1].value


def _recover(lexer: _Lexer, root: _Scanner) -> Token | None:
    try:
        return lexer.next(root)
    except UnexpectedCharacters:
        return None


def _start(meta: Meta | Token) -> tuple[int, int, int]:
    if isinstance(meta, Token):
        return meta.line, meta.column, meta.start_pos
    assert meta.start is not None
    return meta.start


def _end(meta: Meta | Token) -> tuple[int, int, int]:
    if isinstance(meta, Token):
        return meta.end_line, meta.end_column, meta.end_pos
    assert meta.end is not None
    return meta.end


def _reduce(rule: _Rule, children: list[_Entry], builder: Any) -> _Entry:
    first = last = None
    for entry in children:
        if isinstance(entry.meta, Token) or not entry.meta.empty:
            first = entry.meta
            break
    for entry in reversed(children):
        if isinstance(entry.meta, Token) or not entry.meta.empty:
            last = entry.meta
            break
    kept: list[_Entry] = []
    if rule.keep is None:
        kept = children
    elif rule.keep:
        # A list `x*` grows one reduction at a time (`_star: x | _star x`): extend its list in
        # place (it belongs to that stack entry alone) rather than copy it, or n items cost n^2.
        head, splice = rule.keep[0]
        kept = children[head].value if splice else [children[head]]
        for i, splice in rule.keep[1:]:
            if splice:
                kept.extend(children[i].value)
            else:
                kept.append(children[i])
    if rule.expand1 and len(kept) == 1:
        passed = kept[0]
        meta = passed.meta
        if isinstance(meta, Meta):   # lark's positions of a node passed up by a `?rule`
            if first is not None:
                meta.start = _start(first)
                if meta.line is None:
                    meta.line, meta.column, meta.start_pos = meta.start
                    meta.empty = False
            if last is not None:
                meta.end = _end(last)
                if meta.end_line is None:
                    meta.end_line, meta.end_column, meta.end_pos = meta.end
                    meta.empty = False
        return passed
    meta = Meta()
    if first is not None:
        meta.start = _start(first)
        meta.line, meta.column, meta.start_pos = meta.start
        meta.empty = False
    if last is not None:
        meta.end = _end(last)
        meta.end_line, meta.end_column, meta.end_pos = meta.end
        meta.empty = False
    if rule.splice:
        return _Entry(kept, meta)
    return _Entry(getattr(builder, rule.name)(meta, [e.value for e in kept]), meta)
