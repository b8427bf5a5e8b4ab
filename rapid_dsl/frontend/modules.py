"""Module resolution: follow `use` declarations, parse every file once, build each file's top-level
name table, and report cycles, missing files, unknown standard-library names and duplicates.

`use stdlib.NAME` looks for the declaration NAME in the file NAME.rapid of the standard-library
folder (which may also declare helpers for it); `use "rel/path.rapid"` brings every declaration of
that file, the path taken relative to the using file. Only a file's own declarations are brought
in: what a file itself brings in with `use` is not passed on.

A used file must be a program file (language/sources.py) inside the root file's folder tree, or
inside a folder the person running rapidc allowed (`--allow-path`), symlinks resolved; anything
else is an error before the file is read, so a diagnostic never quotes any other file.
Standard-library files stay inside the standard-library folder.
"""

from __future__ import annotations

import difflib
import os
from collections.abc import Callable, Iterable, Sequence
from dataclasses import dataclass, field
from importlib import resources
from importlib.resources.abc import Traversable
from pathlib import Path

from rapid_dsl.frontend import syntax as ast
from rapid_dsl.language.diagnostics import Diagnostic, Span, error
from rapid_dsl.language.files import FileProblem, decode_text, inside, read_text
from rapid_dsl.language.sources import SOURCE_SUFFIXES, is_program_name

STDLIB_PREFIX = "<stdlib>"
RESERVED = frozenset({"start"})  # special forms of the language, not registry builtins

Parse = Callable[[str, str], tuple[ast.Module | None, list[Diagnostic]]]
Named = ast.RelationDecl | ast.DefDecl | ast.Primitive | ast.Strategy
StdlibLocation = str | os.PathLike[str] | Traversable


@dataclass(eq=False)
class SourceFile:
    """One parsed file. `path` is what diagnostics show; `key` identifies the file on disk."""

    path: str
    key: str
    text: str
    module: ast.Module | None
    folder: Traversable | None          # where relative `use` paths start
    is_stdlib: bool = False
    incomplete: bool = False            # some `use` of it failed: unknown names may be its fault
    location: str | None = None         # the file on disk, if it is one (outputs must not hit it)


@dataclass(frozen=True, eq=False)
class Entry:
    """A declaration visible at the top level of a file, and the file that declares it."""

    name: str
    decl: Named
    file: SourceFile
    use: ast.Use | None = None          # the `use` that brought it, None for a local declaration
    where: Span | None = None           # the name in the `use` (or the whole `use` of a file)


@dataclass(eq=False)
class ModuleGraph:
    root: SourceFile
    files: list[SourceFile] = field(default_factory=list)        # root first, then load order
    scopes: dict[str, dict[str, Entry]] = field(default_factory=dict)   # file key -> name -> entry
    diagnostics: list[Diagnostic] = field(default_factory=list)

    def scope(self, file: SourceFile) -> dict[str, Entry]:
        return self.scopes[file.key]


class Stdlib:
    """The standard-library folder: one `NAME.rapid` per primitive."""

    def __init__(self, location: StdlibLocation | None = None) -> None:
        if location is None:
            self.folder: Traversable = resources.files("rapid_dsl.stdlib_primitives")
        elif isinstance(location, (str, os.PathLike)):
            self.folder = Path(location)
        else:
            self.folder = location

    def names(self) -> list[str]:
        try:
            entries = list(self.folder.iterdir())
        except OSError:
            return []
        return sorted(e.name[:-6] for e in entries if e.name.endswith(".rapid") and e.is_file())

    def file(self, name: str) -> Traversable:
        return self.folder.joinpath(f"{name}.rapid")


def declared_name(decl: ast.Decl) -> ast.Name | None:
    return None if isinstance(decl, ast.Use) else decl.name


def did_you_mean(name: str, candidates: Iterable[str]) -> str | None:
    match = difflib.get_close_matches(name, list(candidates), n=1, cutoff=0.6)
    return f"did you mean `{match[0]}`?" if match else None


class _Loader:
    def __init__(self, parse: Parse, stdlib: Stdlib, roots: Sequence[str]) -> None:
        self.parse = parse
        self.stdlib = stdlib
        self.roots = roots                          # folder trees used files must lie in
        self.by_key: dict[str, SourceFile] = {}
        self.active: list[SourceFile] = []          # files whose `use`s are being followed
        self.done: set[str] = set()
        self.graph: ModuleGraph | None = None

    # files --------------------------------------------------------------------------------------
    def load_root(self, root: SourceFile) -> ModuleGraph:
        self.graph = ModuleGraph(root)
        self.by_key[root.key] = root
        self.graph.files.append(root)
        self.follow(root)
        return self.graph

    def open(self, location: Traversable, key: str, path: str, folder: Traversable,
             is_stdlib: bool) -> SourceFile | str:
        """The file at `location`, parsed once; or a reason it cannot be read."""
        if key in self.by_key:
            return self.by_key[key]
        disk = os.fspath(location) if isinstance(location, os.PathLike) else None
        try:
            # Bounded, regular files only; a packaged standard library may live in a zip.
            text = ast.source_text(read_text(disk) if disk is not None
                                   else decode_text(location.read_bytes()))
        except FileProblem as exc:
            return str(exc)
        except OSError as exc:
            return exc.strerror or type(exc).__name__
        module, diagnostics = self.parse(text, path)
        file = SourceFile(path, key, text, module, folder, is_stdlib, location=disk)
        assert self.graph is not None
        self.graph.diagnostics.extend(diagnostics)
        self.by_key[key] = file
        self.graph.files.append(file)
        return file

    def follow(self, file: SourceFile) -> None:
        """Resolve the `use`s of `file` (depth first) and build its top-level name table."""
        assert self.graph is not None
        self.active.append(file)
        scope: dict[str, Entry] = {}
        self.graph.scopes[file.key] = scope
        decls = file.module.decls if file.module else ()
        for decl in decls:
            if isinstance(decl, ast.Use):
                for entry in self.resolve_use(file, decl):
                    self.add_imported(scope, entry)
        for decl in decls:
            name = declared_name(decl)
            if name is not None and not isinstance(decl, ast.Use):
                self.add_local(scope, Entry(name.name, decl, file))
        self.active.pop()
        self.done.add(file.key)

    # `use` ----------------------------------------------------------------------------------------
    def resolve_use(self, file: SourceFile, use: ast.Use) -> list[Entry]:
        if use.file is not None:
            return self.use_file(file, use)
        if use.module != ("stdlib",):
            # `use push` already has a parser error (E0108); other module paths are unknown.
            if use.module:
                module = ".".join(use.module)
                self.report(error(
                    "E0208", f"unknown module `{module}`", use.span,
                    help="declarations come from `stdlib` (`use stdlib.push`) or from a file "
                         "(`use \"lib/shelf.rapid\"`)"))
            file.incomplete = True
            return []
        entries = []
        for name in use.names:
            entry = self.use_stdlib(file, use, name)
            if entry is not None:
                entries.append(entry)
        return entries

    def use_stdlib(self, file: SourceFile, use: ast.Use, name: ast.Name) -> Entry | None:
        available = self.stdlib.names()
        if name.name not in available:
            file.incomplete = True
            listing = ", ".join(f"`{n}`" for n in available) or "none"
            hint = did_you_mean(name.name, available)
            help_text = f"{hint + ' ' if hint else ''}the standard library has: {listing}"
            self.report(error("E0205", f"the standard library has no `{name.name}`",
                                    name.span, help=help_text))
            return None
        target = self.load(file, use, self.stdlib.file(name.name),
                           f"{STDLIB_PREFIX}:{name.name}.rapid",
                           f"{STDLIB_PREFIX}/{name.name}.rapid", self.stdlib.folder, True)
        if target is None:
            return None
        entry = self.graph_scope(target).get(name.name) if target.module else None
        if entry is None or entry.file is not target:
            if target.module is not None:
                self.report(error(
                    "E0205", f"`{target.path}` does not declare `{name.name}`", name.span,
                    help="a standard-library file NAME.rapid must declare NAME"))
            file.incomplete = True
            return None
        return Entry(name.name, entry.decl, target, use, name.span)

    def use_file(self, file: SourceFile, use: ast.Use) -> list[Entry]:
        assert use.file is not None
        rel = use.file
        if "\0" in rel:   # no file system has such a name; os.path refuses it with ValueError
            self.report(error("E0206", "cannot use a path that holds a NUL character", use.span))
            file.incomplete = True
            return []
        if file.folder is None or not rel or os.path.isabs(rel):
            self.report(error("E0206", f"cannot use `{rel}`: give a path relative to this file",
                                    use.span))
            file.incomplete = True
            return []
        location = file.folder.joinpath(*_parts(rel))
        shown = os.path.normpath(os.path.join(os.path.dirname(file.path), rel))
        refusal = self.refuse(file, use, rel, location)
        if refusal is not None:
            self.report(refusal)
            file.incomplete = True
            return []
        if file.is_stdlib:
            within = file.key.split(":", 1)[1]
            key = f"{STDLIB_PREFIX}:{os.path.normpath(os.path.join(os.path.dirname(within), rel))}"
        else:
            key = os.path.realpath(str(location))
        folder = file.folder.joinpath(*_parts(os.path.dirname(rel))) if os.path.dirname(rel) \
            else file.folder
        target = self.load(file, use, location, key, shown, folder, file.is_stdlib)
        if target is None:
            return []
        if target.module is None:
            file.incomplete = True
            return []
        return [Entry(e.name, e.decl, target, use, use.span)
                for e in self.graph_scope(target).values() if e.file is target]

    def refuse(self, file: SourceFile, use: ast.Use, rel: str,
               location: Traversable) -> Diagnostic | None:
        """Why `use "rel"` may not be read, or None. Decided from names alone, before reading."""
        span = _path_span(file, use)
        if file.is_stdlib:
            trees: Sequence[str | os.PathLike[str]] = \
                [self.stdlib.folder] if isinstance(self.stdlib.folder, os.PathLike) else []
            where = "the standard library's folder"
            escapes = os.path.normpath(os.path.join(
                os.path.dirname(file.key.split(":", 1)[1]), rel)).startswith("..")
            widen = "a standard-library file uses only files of the standard library"
        else:
            trees, where, escapes = self.roots, "the checked program's folder", False
            widen = "to allow another folder, run rapidc with `--allow-path DIR`"
        disk = os.fspath(location) if isinstance(location, os.PathLike) else None
        if escapes or disk is not None and trees and not inside(disk, trees):
            return error("E0216", f"`{rel}` is outside {where}", span,
                         help=f"used files must be in that folder or below it, symlinks "
                              f"resolved; {widen}")
        resolved = os.path.basename(os.path.realpath(disk)) if disk is not None else rel
        if not is_program_name(rel):
            what = f"`{rel}` is"
        elif not is_program_name(resolved):   # a link named x.rapid to some other file
            what = f"`{rel}` links to `{resolved}`, which is"
        else:
            return None
        return error("E0217", f"{what} not a program file", span,
                     help=f"a used file's name ends in {_suffix_list()}; other files are not read")

    def load(self, file: SourceFile, use: ast.Use, location: Traversable, key: str, shown: str,
             folder: Traversable, is_stdlib: bool) -> SourceFile | None:
        """Open and follow the used file; report cycles and unreadable files at the `use`."""
        for i, active in enumerate(self.active):
            if active.key == key:
                chain = " -> ".join(f.path for f in [*self.active[i:], active])
                self.report(error("E0207", f"`use` cycle: {chain}", use.span,
                                        help="move the shared declarations into a file that both "
                                             "use"))
                return active if active.module is not None else None
        target = self.open(location, key, shown, folder, is_stdlib)
        if isinstance(target, str):
            self.report(error("E0206", f"cannot read `{shown}`: {target}", use.span,
                                    help="the path is relative to the file with the `use`"))
            file.incomplete = True
            return None
        if target.key not in self.done and target not in self.active:
            self.follow(target)
        if target.incomplete:
            file.incomplete = True
        return target

    def graph_scope(self, target: SourceFile) -> dict[str, Entry]:
        assert self.graph is not None
        return self.graph.scopes.get(target.key, {})

    # name tables ----------------------------------------------------------------------------------
    def add_imported(self, scope: dict[str, Entry], entry: Entry) -> None:
        previous = scope.get(entry.name)
        assert entry.use is not None
        if previous is not None:
            same = previous.decl is entry.decl
            what = "again" if same else f"a second time (from `{entry.file.path}`)"
            assert previous.use is not None
            self.report(error(
                "E0203", f"`use` brings `{entry.name}` {what}", _use_name_span(entry),
                related=[("first brought in", _use_name_span(previous))],
                help="remove one of the two" if same else "rename one declaration"))
            return
        scope[entry.name] = entry

    def add_local(self, scope: dict[str, Entry], entry: Entry) -> None:
        name_span = entry.decl.name.span
        # Builtin names are free: primitives and strategies run only in phases, and a user
        # `def`/relation named like a builtin wins in its file (lint W0109 says so).
        if entry.name in RESERVED:
            self.report(error(
                "E0215", f"`{entry.name}` is a special form and cannot be declared again",
                name_span, help="choose another name"))
            return
        previous = scope.get(entry.name)
        if previous is not None and previous.use is not None:
            self.report(error(
                "E0204", f"`{entry.name}` is declared here and also brought in by `use`",
                name_span, related=[("brought in", _use_name_span(previous))],
                help="rename the local declaration or drop the `use`"))
            return
        if previous is not None:
            self.report(error(
                "E0202", f"`{entry.name}` is declared twice", name_span,
                related=[("first declared", previous.decl.name.span)],
                help="names are unique per file"))
            return
        scope[entry.name] = entry

    def report(self, diagnostic: Diagnostic) -> None:
        assert self.graph is not None
        self.graph.diagnostics.append(diagnostic)


def _use_name_span(entry: Entry) -> Span:
    assert entry.use is not None
    return entry.where or entry.use.span


def _parts(rel: str) -> list[str]:
    return [p for p in rel.replace("\\", "/").split("/") if p and p != "."]


def _suffix_list() -> str:
    names = [f"`{s}`" for s in SOURCE_SUFFIXES]
    return ", ".join(names[:-1]) + f" or {names[-1]}"


def _path_span(file: SourceFile, use: ast.Use) -> Span:
    """The span of the path string in `use "path"` (or the YAML `use:` value), found in the text
    of the `use`; the whole `use` when it cannot be found (a YAML value with escapes)."""
    segment = file.text[use.span.start:use.span.end]
    assert use.file is not None
    if file.path.endswith((".yaml", ".yml")):
        start = segment.find(use.file)
        end = start + len(use.file)
    else:
        start, end = segment.find('"'), len(segment)
    if start < 0 or "\n" in segment[start:end]:
        return use.span

    def at(offset: int) -> tuple[int, int]:
        before = segment[:offset]
        newline = before.rfind("\n")
        if newline < 0:
            return use.span.line, use.span.col + offset
        return use.span.line + before.count("\n"), offset - newline

    (line, col), (end_line, end_col) = at(start), at(end)
    return Span(use.span.path, use.span.start + start, use.span.start + end, line, col,
                end_line, end_col)


def load_modules(text: str, path: str, module: ast.Module | None, *, parse: Parse,
                 stdlib: StdlibLocation | None = None,
                 allowed_dirs: Sequence[str | os.PathLike[str]] = ()) -> ModuleGraph:
    """Resolve every `use` reachable from the root file (already parsed as `module`). Used files
    must lie in the root file's folder tree or in one of `allowed_dirs`."""
    folder = Path(os.path.dirname(os.path.abspath(path)))
    location = path if os.path.isfile(path) else None
    root = SourceFile(path, os.path.realpath(path), text, module, folder, location=location)
    roots = [str(folder), *map(str, allowed_dirs)]
    return _Loader(parse, Stdlib(stdlib), roots).load_root(root)
