"""A tool call's JSON arguments -> its `rapidc` command's argv, kept inside the server's folders.

The person who starts `rapidc mcp` is trusted, as on the command line; a tool call's arguments are
not (an agent writes them, as it writes programs). So every path a call names, to read or to
write, must lie (symlinks resolved) in the server's root folder or an `--allow-path` folder of its
command line; the standard library may be read, not written. `--allow-path` is passed on to every
command that takes it, so `use` paths and scene meshes follow the command line's rules
(docs/security.md) with the same folders.

A file given as text (`text`, `scene_text`, ...) is written to a temporary folder made for the
call, under `name` for a program, and the command reads it there; the folder's path is taken out
of everything the call returns, so diagnostics name the file as `name`.
"""

from __future__ import annotations

import json
import os
import shutil
import tempfile
from collections.abc import Iterator, Mapping
from contextlib import contextmanager
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from rapid_dsl.language.files import FileProblem, inside, write_atomic
from rapid_dsl.language.sources import is_program_name
from rapid_dsl.mcp.tools import (
    Parameter,
    ToolSpec,
    inline_inputs,
    parameters,
    takes,
    text_parameter,
)

# the file name of each inline text (a program's may be chosen with `name`)
DEFAULT_NAMES = {"text": "program.rapid", "scene_text": "scene.yaml", "ranges_text": "ranges.yaml"}
_NAME_LIMIT = 200


class CallProblem(ValueError):
    """The call's arguments cannot be used; the message says why (a usage error, exit 2)."""


@dataclass(frozen=True, slots=True)
class Workspace:
    """The folders tool calls may name: `root` (relative paths start there) and --allow-path."""

    root: Path
    allowed_dirs: tuple[str, ...] = ()
    read_only: tuple[Path, ...] = field(default_factory=lambda: (_stdlib_folder(),))

    @property
    def roots(self) -> tuple[Path, ...]:
        return (self.root, *(Path(d) for d in self.allowed_dirs))

    def check(self, path: str, what: str, *, write: bool) -> None:
        """Refuse a path outside the folders (outside the writable ones, for an output); a
        relative path starts at the root, where the server runs its commands."""
        where = self.root / path
        if write and inside(where, self.read_only):
            raise CallProblem(f"{what} {path}: the standard library may be read, not written")
        roots = self.roots if write else (*self.roots, *self.read_only)
        if not inside(where, roots):
            folders = ", ".join(str(r) for r in self.roots)
            raise CallProblem(f"{what} {path}: outside the folders this server may use "
                              f"({folders}); start `rapidc mcp` with --allow-path DIR to add one")


def _stdlib_folder() -> Path:
    from rapid_dsl import stdlib_primitives

    return Path(stdlib_primitives.__file__).parent


@dataclass
class Call:
    """A call ready to run: its argv, and the temporary folder its inline files are in."""

    spec: ToolSpec
    argv: list[str]
    folder: Path | None = None
    result_file: str | None = None     # where the result JSON is written (run's trace)

    def result(self) -> Any:
        """The JSON of the result file, or None if the command did not write it (or what is
        there is not JSON the strict reader takes: a call that failed may leave a file the
        caller put there)."""
        from rapid_dsl.language.files import FileProblem, read_text
        from rapid_dsl.language.safe_json import JsonError, loads

        if self.result_file is None or not os.path.isfile(self.result_file):
            return None
        try:
            return loads(read_text(self.result_file), self.result_file)
        except (FileProblem, JsonError):
            return None

    def unmask(self, value: Any) -> Any:
        """`value` with the temporary folder left out of every string in it."""
        if self.folder is None:
            return value
        prefixes = {f"{self.folder}{os.sep}", f"{os.path.realpath(self.folder)}{os.sep}"}

        def clean(item: Any) -> Any:
            if isinstance(item, str):
                for prefix in prefixes:
                    item = item.replace(prefix, "")
                return item
            if isinstance(item, list):
                return [clean(i) for i in item]
            if isinstance(item, dict):
                return {clean(k): clean(v) for k, v in item.items()}
            return item
        return clean(value)


@contextmanager
def prepared(spec: ToolSpec, arguments: Mapping[str, Any], workspace: Workspace) -> Iterator[Call]:
    """The call's argv (raises CallProblem); its temporary folder is removed afterwards."""
    call = Call(spec, [])
    try:
        call.argv = _argv(spec, dict(arguments), workspace, call)
        yield call
    finally:
        if call.folder is not None:
            shutil.rmtree(call.folder, ignore_errors=True)


def _argv(spec: ToolSpec, arguments: dict[str, Any], workspace: Workspace, call: Call) -> list[str]:
    params = {p.name: p for p in parameters(spec)}
    texts = {text_parameter(p.name): p for p in inline_inputs(spec)}
    known = {*params, *texts, *(("name",) if "text" in texts else ())}
    unknown = sorted(set(arguments) - known)
    if unknown:
        raise CallProblem(f"unknown argument `{unknown[0]}`; {spec.name} takes "
                          + ", ".join(f"`{k}`" for k in sorted(known)))
    name = arguments.pop("name", None)
    if name is not None and "text" not in arguments:
        raise CallProblem("`name` names the file of `text`; give `text` too")
    for key, param in texts.items():
        if key in arguments:
            text = _string(arguments.pop(key), key)
            given = arguments.get(param.name)
            if given is not None and not param.many:
                raise CallProblem(f"give `{param.name}` or `{key}`, not both")
            file = _write_inline(call, key, text, name if key == "text" else None)
            arguments[param.name] = [*_strings(given, param.name), file] if param.many else file
    for dest, default in spec.defaults:
        param = next(p for p in params.values() if p.dest == dest)
        arguments.setdefault(param.name, default)
    if spec.result_file is not None:
        result = next(p for p in params.values() if p.dest == spec.result_file)
        if arguments.get(result.name) is None:
            arguments[result.name] = str(_folder(call) / f"{result.dest}.json")
        call.result_file = str(arguments[result.name])

    argv = [*spec.command, "--format", "json", "--color", "never"]
    if takes(spec, "allowed_dirs"):
        for folder in workspace.allowed_dirs:
            argv.append(f"--allow-path={folder}")
    positionals: list[str] = []
    for param in params.values():
        value = arguments.get(param.name)
        if value is None:
            if param.required:
                alternative = next((k for k, p in texts.items() if p is param), None)
                raise CallProblem(f"missing argument `{param.name}`"
                                  + (f" (or `{alternative}`)" if alternative else ""))
            continue
        words = _words(param, value)
        _confine(spec, param, words, workspace, call)
        if param.kind == "positional":
            positionals += words
        elif param.kind == "flag":
            argv += [str(param.option)] if words else []
        else:
            argv += [f"{param.option}={word}" for word in words]
    # `--`: a path that starts with `-` is still a path (a nested command's parser refuses a
    # bare `--` with nothing after it)
    return [*argv, "--", *positionals] if positionals else argv


def _words(param: Parameter, value: Any) -> list[str]:
    """The argument's values as command-line words, checked against the parameter's type."""
    if param.json_type == "boolean":
        if not isinstance(value, bool):
            raise CallProblem(f"`{param.name}` is true or false, got {_shown(value)}")
        return ["true"] if value else []
    if param.pairs and isinstance(value, dict):
        return [f"{_scalar('string', k, param.name)}={_scalar('string', v, param.name)}"
                for k, v in value.items()]
    if param.many:
        items = value if isinstance(value, list) else [value]
        return [_scalar(param.json_type, item, param.name) for item in items]
    return [_scalar(param.json_type, value, param.name)]


def _scalar(json_type: str, value: Any, name: str) -> str:
    if json_type == "string":
        return _string(value, name)
    wanted = int if json_type == "integer" else (int, float)
    if isinstance(value, bool) or not isinstance(value, wanted):
        raise CallProblem(f"`{name}` is {'an integer' if json_type == 'integer' else 'a number'}"
                          f", got {_shown(value)}")
    return repr(value)


def _string(value: Any, name: str) -> str:
    if isinstance(value, bool) or not isinstance(value, str | int | float):
        raise CallProblem(f"`{name}` is text, got {_shown(value)}")
    text = str(value)
    if "\0" in text:
        raise CallProblem(f"`{name}` holds a NUL character")
    return text


def _strings(value: Any, name: str) -> list[str]:
    if value is None:
        return []
    return [_string(v, name) for v in (value if isinstance(value, list) else [value])]


def _shown(value: Any) -> str:
    text = json.dumps(value)
    return text if len(text) <= 40 else text[:37] + "..."


def _confine(spec: ToolSpec, param: Parameter, words: list[str], workspace: Workspace,
             call: Call) -> None:
    writes = param.dest in spec.writes
    if param.dest not in spec.reads and not writes:
        return
    for word in words:
        if word == "-" and writes:
            continue    # standard output (compile -o -)
        if call.folder is not None and inside(word, [call.folder]):
            continue    # the call's own temporary files
        workspace.check(word, f"`{param.name}`", write=writes)


def _folder(call: Call) -> Path:
    if call.folder is None:
        call.folder = Path(tempfile.mkdtemp(prefix="rapidc-mcp-"))
    return call.folder


def _write_inline(call: Call, key: str, text: str, name: Any) -> str:
    """Write an inline file into the call's temporary folder; returns its path."""
    file_name = DEFAULT_NAMES[key] if name is None else _string(name, "name")
    if (not file_name or len(file_name) > _NAME_LIMIT or file_name in (".", "..")
            or any(c in file_name for c in "/\\") or not file_name.isprintable()):
        raise CallProblem(f"`name` {_shown(file_name)}: a plain file name, e.g. nudge.rapid")
    if key == "text" and not is_program_name(file_name):
        raise CallProblem(f"`name` {_shown(file_name)}: a program's name ends in .rapid, "
                          ".rapid.yaml or .rapid.yml")
    try:
        data = text.encode("utf-8")
    except UnicodeEncodeError:
        raise CallProblem(f"`{key}` is not valid Unicode (a lone surrogate)") from None
    path = _folder(call) / file_name
    try:
        write_atomic(path, data)
    except FileProblem as exc:
        raise CallProblem(f"`name` {_shown(file_name)}: cannot write it: {exc}") from None
    return str(path)
