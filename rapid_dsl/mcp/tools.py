"""The MCP tools: one `ToolSpec` per tool, and its parameters read from its command's parser.

A tool is a `rapidc` command. Its parameters are the command's own options, read from the argparse
parser the command line builds (`rapid_dsl.cli.build_parser`), so the names, help texts, defaults
and validation are the command line's: `--samples N` is `"samples": 8`, `--bind role=entity` is
`"bind": {"role": "entity"}` (or `["role=entity"]`), `--best` is `"best": true`, the program is
`"path"`. Options the server decides are not parameters: `--format` (always json), `--color`
(never), `--allow-path` (given once, on `rapidc mcp`'s command line) and verify's `--cluster`
(a tool call does not choose where the server sends programs).

To add a tool, add one entry to TOOLS naming the command's words and how each string option is
used: `reads` (files or folders read), `writes` (written) or `plain` (names no file), and `texts`
(read files that may be given as text). An option left out of reads, writes and plain is not
offered (a path the server does not know about cannot be kept in its folders), and
tests/mcp/test_mcp_tools.py fails until it is placed.
"""

from __future__ import annotations

import argparse
from dataclasses import dataclass
from functools import cache
from typing import Any, Literal

Stdout = Literal["diagnostics", "json", "text"]

# Options of every command that the server sets itself, and verify's scheduler address.
SERVER_OPTIONS = frozenset({"help", "format", "color", "allowed_dirs", "cluster"})
# String options, in the commands that have them, that name no file.
PLAIN = ("entry", "bind", "hint", "arg", "code")
# The program a command reads is the parameter `path` (`paths` where a command takes several).
RENAMED = {"file": "path", "program": "path"}


@dataclass(frozen=True, slots=True)
class ToolSpec:
    name: str
    command: tuple[str, ...]                   # the rapidc command's words: ("demo", "analyze")
    reads: tuple[str, ...] = ()                # dests of options that name files or folders read
    writes: tuple[str, ...] = ()               # ... and written (kept out of read-only folders)
    plain: tuple[str, ...] = PLAIN             # string options that name no file
    texts: tuple[str, ...] = ()                # read files that may be given as text instead
    stdout: Stdout = "json"                    # what the command prints with --format json
    result_file: str | None = None             # an output option whose JSON file is the result
    worker: bool = False                       # long: a worker process, with progress
    jobs: str | None = None                    # the parameter that sets how many processes it
                                               # keeps busy (verify's jobs); else one
    read_only: bool = False                    # changes no file (a hint to the client)
    defaults: tuple[tuple[str, str], ...] = ()  # (dest, value): the server's defaults
    optional: bool = False                     # listed only once the command exists


TOOLS: tuple[ToolSpec, ...] = (
    ToolSpec("check", ("check",), reads=("paths",), texts=("paths",), stdout="diagnostics",
             read_only=True),
    ToolSpec("lint", ("lint",), reads=("paths",), texts=("paths",), stdout="diagnostics",
             read_only=True),
    # fmt --write rewrites the files it is given: they are outputs too
    ToolSpec("fmt", ("fmt",), reads=("paths",), writes=("paths",), texts=("paths",),
             stdout="text"),
    ToolSpec("compile", ("compile",), reads=("file",), writes=("output",), texts=("file",),
             stdout="text", defaults=(("output", "-"),)),  # the module comes back in `output`
    ToolSpec("bind", ("bind",), reads=("program", "scene"), texts=("program", "scene"),
             read_only=True),
    ToolSpec("run", ("run",), reads=("program", "scene"),
             writes=("trace", "track", "video", "keyframes"), texts=("program", "scene"),
             stdout="text", result_file="trace", worker=True),
    ToolSpec("verify", ("verify",), reads=("program", "scene", "ranges"),
             writes=("report", "resume", "media", "html"), texts=("program", "scene", "ranges"),
             worker=True, jobs="jobs"),
    ToolSpec("variants", ("variants",), reads=("scene", "ranges"), writes=("output",),
             texts=("scene", "ranges"), worker=True),
    ToolSpec("explain", ("explain",), stdout="text", read_only=True),
    ToolSpec("demo_analyze", ("demo", "analyze"), reads=("track",), writes=("skeleton",),
             optional=True),
    ToolSpec("scene_from_rgbd", ("scene", "from-rgbd"),
             reads=("rgb", "depth", "intrinsics", "masks", "labels", "extrinsics"),
             writes=("output",), worker=True, optional=True),
)

Kind = Literal["positional", "flag", "option", "append"]


@dataclass(frozen=True, slots=True)
class Parameter:
    """One option of a command as a tool parameter."""

    name: str                       # the JSON property
    dest: str                       # argparse's dest
    kind: Kind
    option: str | None              # the long option string; None for a positional
    json_type: str                  # string, integer, number or boolean (of the items, for lists)
    many: bool                      # a list (a positional with nargs + or a repeatable option)
    pairs: bool                     # NAME=VALUE items, also given as an object
    required: bool
    help: str
    metavar: str
    default: Any = None
    choices: tuple[str, ...] | None = None


class UnknownCommand(LookupError):
    """The command line has no such command (an optional tool whose command is not there yet)."""


@cache
def command_parser(command: tuple[str, ...]) -> argparse.ArgumentParser:
    """The argparse parser of `rapidc COMMAND...`, as the command line builds it (read here,
    never used to parse: each call's command builds its own)."""
    from rapid_dsl.cli import build_parser

    parser = build_parser(list(command))
    for word in command:
        parser = _subcommand(parser, word)
    return parser


def _subcommand(parser: argparse.ArgumentParser, word: str) -> argparse.ArgumentParser:
    for action in parser._actions:
        if isinstance(action, argparse._SubParsersAction) and word in action.choices:
            sub: argparse.ArgumentParser = action.choices[word]
            return sub
    raise UnknownCommand(word)


@cache
def parameters(spec: ToolSpec) -> tuple[Parameter, ...]:
    """The tool's parameters, in the order of the command's options. Raises UnknownCommand."""
    return tuple(p for p, placed in _options(spec) if placed)


def unplaced(spec: ToolSpec) -> list[str]:
    """String options of the command that the spec does not place (and so does not offer)."""
    return [p.dest for p, placed in _options(spec) if not placed]


def _options(spec: ToolSpec) -> list[tuple[Parameter, bool]]:
    """Every option of the command but the server's, and whether the tool may offer it: a free
    string option may name a file, which the server must know to keep inside its folders."""
    placed = {*spec.reads, *spec.writes, *spec.plain}
    options = []
    for action in command_parser(spec.command)._actions:
        if action.dest in SERVER_OPTIONS or isinstance(action, argparse._SubParsersAction):
            continue
        p = _parameter(action, spec)
        options.append((p, p.json_type != "string" or bool(p.choices) or p.dest in placed))
    return options


def _parameter(action: argparse.Action, spec: ToolSpec) -> Parameter:
    positional = not action.option_strings
    name = RENAMED.get(action.dest, action.dest) if positional else action.dest
    if isinstance(action, argparse._StoreTrueAction):
        kind: Kind = "flag"
    elif positional:
        kind = "positional"
    elif isinstance(action, argparse._AppendAction):
        kind = "append"
    else:
        kind = "option"
    longs = [o for o in action.option_strings if o.startswith("--")]
    many = kind == "append" or action.nargs in ("+", "*")
    default = dict(spec.defaults).get(action.dest, action.default)
    if default in (None, [], False, argparse.SUPPRESS):
        default = None
    return Parameter(
        name=name, dest=action.dest, kind=kind, option=longs[0] if longs else None,
        json_type="boolean" if kind == "flag" else _value_type(action),
        many=many, pairs="=" in str(action.metavar or ""),
        required=action.required and action.dest not in dict(spec.defaults),
        help=" ".join((action.help or str(action.metavar or "")).split()),
        metavar=str(action.metavar or action.dest.upper()), default=default,
        choices=tuple(action.choices) if action.choices else None)


def _value_type(action: argparse.Action) -> str:
    """What the option's own type function makes of "1": an int, a float, or text."""
    convert = action.type
    if convert is None or convert is str or not callable(convert):
        return "string"
    try:
        value = convert("1")
    except (argparse.ArgumentTypeError, TypeError, ValueError):
        return "string"
    if isinstance(value, bool) or not isinstance(value, int | float):
        return "string"
    return "integer" if isinstance(value, int) else "number"


def takes(spec: ToolSpec, dest: str) -> bool:
    """Whether the tool's command has the option `dest` (`allowed_dirs`: --allow-path)."""
    return any(a.dest == dest for a in command_parser(spec.command)._actions)


def text_parameter(name: str) -> str:
    """The parameter that gives the file of parameter `name` as text: `path` -> `text`."""
    return "text" if name in ("path", "paths") else f"{name}_text"


def inline_inputs(spec: ToolSpec) -> list[Parameter]:
    """The file parameters that may be given as text instead: the program, the scene, ranges."""
    return [p for p in parameters(spec) if p.dest in spec.texts]


def input_schema(spec: ToolSpec) -> dict[str, Any]:
    properties: dict[str, Any] = {}
    required: list[str] = []
    inline = {p.name for p in inline_inputs(spec)}
    for p in parameters(spec):
        properties[p.name] = _property(p)
        if p.name in inline:
            text = text_parameter(p.name)
            properties[text] = {
                "type": "string",
                "description": f"instead of `{p.name}`: the file's content, read as a file in a "
                               "temporary folder (its `use`s and meshes must then be standard "
                               "library ones or under --allow-path folders)"}
            if p.name in ("path", "paths"):
                properties["name"] = {
                    "type": "string",
                    "description": "the file name `text` is checked under (default "
                                   "program.rapid; end it in .rapid.yaml for the YAML form); "
                                   "diagnostics name it"}
        elif p.required:
            required.append(p.name)
    schema: dict[str, Any] = {"type": "object", "properties": properties,
                              "additionalProperties": False}
    if required:
        schema["required"] = required
    return schema


def _property(p: Parameter) -> dict[str, Any]:
    item: dict[str, Any] = {"type": p.json_type}
    if p.choices:
        item["enum"] = list(p.choices)
    if p.pairs:
        value: dict[str, Any] = {
            "anyOf": [{"type": "object", "additionalProperties": {"type": "string"}},
                      {"type": "array", "items": {"type": "string"}}]}
    elif p.many:
        value = {"type": "array", "items": item}
    else:
        value = dict(item)
    help_text = p.help + (f" (the command line's {p.option})" if p.option else "")
    value["description"] = help_text.strip()
    if p.default is not None:
        value["default"] = p.default
    return value


OUTPUT_SCHEMA: dict[str, Any] = {
    "type": "object",
    "properties": {
        "tool": {"type": "string"},
        "exit_status": {"type": "integer",
                        "description": "rapidc's exit status: 0 clean or succeeded, 1 program "
                                       "errors or a run that failed, 2 bad input, 3 internal "
                                       "error, 130 interrupted"},
        "diagnostics": {"type": "array", "items": {"type": "object"},
                        "description": "every diagnostic, as `rapidc check --format json` "
                                       "prints them"},
        "result": {"description": "the JSON the command prints with --format json (bind's "
                                  "ranking, verify's report, variants' list) or writes (run's "
                                  "trace); null for the others"},
        "output": {"type": ["string", "null"],
                   "description": "text the command prints: fmt's program, compile's module, "
                                  "run's result table, explain's title"},
        "messages": {"type": "array", "items": {"type": "string"},
                     "description": "other lines on stderr: usage errors, warnings"},
    },
    "required": ["tool", "exit_status", "diagnostics", "result", "output", "messages"],
}


def available() -> list[ToolSpec]:
    """The tools this rapidc has (an optional tool's command may not be there yet)."""
    tools = []
    for spec in TOOLS:
        try:
            parameters(spec)
        except UnknownCommand:
            if not spec.optional:
                raise
            continue
        tools.append(spec)
    return tools


def describe(spec: ToolSpec) -> str:
    """The tool's description: the command's own, and what the call returns."""
    parser = command_parser(spec.command)
    text = " ".join((parser.description or parser.prog).split())
    text += "" if text.endswith(".") else "."
    returns = {"diagnostics": "`diagnostics` holds its diagnostics",
               "json": "`result` holds the JSON it prints with --format json",
               "text": "`output` holds the text it prints"}[spec.stdout]
    if spec.result_file:
        returns += f"; `result` holds the JSON it writes with --{spec.result_file}"
    inline = {p.name for p in inline_inputs(spec)}
    named = ", ".join(f"{p.metavar} is `{p.name}`"
                      + (f" (or `{text_parameter(p.name)}`)" if p.name in inline else "")
                      for p in parameters(spec) if p.kind == "positional")
    return (f"`rapidc {' '.join(spec.command)}`. {text}" + (f" {named}." if named else "")
            + f" Returns `exit_status` as the command's; {returns}."
            + (" Reports progress." if spec.worker else ""))


def spec_named(name: str) -> ToolSpec | None:
    return next((s for s in available() if s.name == name), None)
