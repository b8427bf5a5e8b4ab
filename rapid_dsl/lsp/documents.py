"""The documents the editor has open: their text as the editor holds it, what the checker calls
them, and what was learned from them (the check's diagnostics, the typed model), per version.

Open documents are checked from the editor's buffer; the files they `use` are read from disk by
module resolution, with the project's path rules (docs/security.md): inside the document's folder
tree or a folder the person starting `rapidc lsp` allowed with `--allow-path`. A document that is
not a file (an unsaved `untitled:` buffer) is checked as a file of an empty folder of its own, so
its relative `use`s find nothing rather than the server's working folder.
"""

from __future__ import annotations

import os
import shutil
import tempfile
from collections.abc import Callable
from dataclasses import dataclass, field

from pygls.uris import from_fs_path, to_fs_path

from rapid_dsl.frontend.driver import CheckResult
from rapid_dsl.frontend.modules import STDLIB_PREFIX, Stdlib
from rapid_dsl.lsp.model import Model
from rapid_dsl.lsp.positions import UTF16, Text

# Language ids an editor may give a document without a file name (VS Code's own are these).
_YAML_LANGUAGES = frozenset({"yaml", "rapid-yaml"})


class BadUri(ValueError):
    """A `file:` URI that names no path the server can read (NUL, text that is not Unicode)."""


@dataclass(eq=False)
class Document:
    uri: str
    version: int
    text: str                       # as the editor holds it (a BOM, CR or CRLF kept)
    path: str                       # what the checker calls it, absolute
    revision: int = 0               # +1 whenever what is learned from it may change
    checked: CheckResult | None = None      # of this version, once published
    model: Model | None = None              # of this version, once a feature needed it
    parsed: str | None = None               # the newest text that parsed (for completion)
    parsed_model: Model | None = None       # the model of `parsed`, once completion needed it
    _lines: Text | None = field(default=None, repr=False)

    def lines(self, encoding: str = UTF16) -> Text:
        if self._lines is None or self._lines.encoding != encoding:
            self._lines = Text(self.text, encoding)
        return self._lines

    def update(self, version: int, text: str) -> None:
        self.version, self.text = version, text
        self.checked = self.model = None
        self._lines = None
        self.revision += 1

    def forget(self) -> None:
        """What was learned from it is out of date: a file it uses changed."""
        self.revision += 1
        self.model = self.parsed_model = None

    def parses(self) -> None:
        """The text parsed: completion reads its names while later versions do not parse."""
        if self.parsed is not self.text:
            self.parsed, self.parsed_model = self.text, None

    @property
    def is_yaml(self) -> bool:
        return self.path.endswith((".yaml", ".yml"))


class Documents:
    """uri -> Document, and the scratch folder of documents that are not files."""

    def __init__(self) -> None:
        self.open: dict[str, Document] = {}
        self._scratch: str | None = None
        self._unnamed = 0

    def add(self, uri: str, version: int, text: str, language: str) -> Document:
        document = Document(uri, version, text, self.path_of(uri, language))
        self.open[uri] = document
        return document

    def get(self, uri: str) -> Document | None:
        return self.open.get(uri)

    def close(self, uri: str) -> None:
        self.open.pop(uri, None)

    def path_of(self, uri: str, language: str) -> str:
        """What the checker calls the document of `uri`; BadUri if a `file:` URI names no path."""
        path = file_path(uri)
        if path:
            return os.path.abspath(path)
        if self._scratch is None:
            self._scratch = tempfile.mkdtemp(prefix="rapidc-lsp-")
        self._unnamed += 1
        suffix = ".rapid.yaml" if language in _YAML_LANGUAGES else ".rapid"
        return os.path.join(self._scratch, f"unsaved-{self._unnamed}{suffix}")

    def uri_finder(self) -> Callable[[str], str | None]:
        """`uri_of` as the open documents are now (for a worker thread, while they change)."""
        opened = {d.path: d.uri for d in reversed(self.open.values())}
        return lambda path: opened.get(path) or _file_uri(path)

    def uri_of(self, path: str) -> str | None:
        """The URI of a checked file's path (an open document's own URI first)."""
        for document in self.open.values():
            if document.path == path:
                return document.uri
        return _file_uri(path)

    def dispose(self) -> None:
        if self._scratch is not None:
            shutil.rmtree(self._scratch, ignore_errors=True)
            self._scratch = None


def file_path(uri: str) -> str | None:
    """The path a `file:` URI names (None for another scheme); BadUri if it names none that can
    be read."""
    path = to_fs_path(uri) if uri.startswith("file:") else None
    if path and "\0" in path:
        raise BadUri(f"the URI {uri[:200]!a} names no file path: it holds a NUL character")
    if path:
        try:
            os.fsencode(path)
        except UnicodeEncodeError:
            raise BadUri(f"the URI {uri[:200]!a} names no file path: it is not Unicode text "
                         "(a lone surrogate)") from None
    return path


def _file_uri(path: str) -> str | None:
    if path.startswith(STDLIB_PREFIX + "/"):
        folder = Stdlib().folder
        if not isinstance(folder, os.PathLike):   # a packaged standard library in a zip
            return None
        path = os.path.join(os.fspath(folder), path.removeprefix(STDLIB_PREFIX + "/"))
    return from_fs_path(path) if os.path.isabs(path) else None
