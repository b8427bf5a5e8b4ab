"""`rapidc lsp`: the language server, over standard input and output, built on pygls.

Diagnostics are the checker's (`driver.check_text`, with lint warnings unless the client's
initialization options say `{"lint": false}`), published when a document opens and shortly after
each change; hover, go to definition, completion and formatting read the document's typed model
(model.py), built once per version when one of them asks. The server keeps its own copy of each
document (documents.py) and converts every position in positions.py.

Every handler catches what it does not expect: a bug answers one request with nothing and is
logged, and the server goes on.
"""

from __future__ import annotations

import asyncio
import contextlib
import functools
import os
import sys
import traceback
from collections.abc import Callable, Sequence
from typing import Any, TypeVar

from lsprotocol import types
from pygls.lsp.server import LanguageServer

from rapid_dsl import __version__
from rapid_dsl.language.files import MAX_INPUT_BYTES
from rapid_dsl.lsp import report
from rapid_dsl.lsp.completion import complete
from rapid_dsl.lsp.definition import definition
from rapid_dsl.lsp.documents import Document, Documents
from rapid_dsl.lsp.hover import hover
from rapid_dsl.lsp.model import Model, build, parses
from rapid_dsl.lsp.positions import ENCODINGS, UTF16, Text

# Changes that arrive within this time are checked once: an editor sends several for one edit
# (a paste with re-indentation, several cursors), and a 200-line check takes about 30 ms.
DEBOUNCE_S = 0.02
LARGE_TEXT = 256 * 1024   # characters; see _release
T = TypeVar("T")


class RapidServer(LanguageServer):
    def __init__(self, allowed_dirs: Sequence[str]) -> None:
        super().__init__("rapidc", __version__,
                         text_document_sync_kind=types.TextDocumentSyncKind.Incremental)
        self.documents = Documents()
        self.allowed_dirs = list(allowed_dirs)
        self.lint = True
        self.shutdown_requested = False
        self.pending: dict[str, asyncio.TimerHandle] = {}

    @property
    def encoding(self) -> str:
        agreed = self.workspace.position_encoding
        value = str(getattr(agreed, "value", agreed) or UTF16)
        return value if value in ENCODINGS else UTF16

    def log(self, message: str) -> None:
        print(f"rapidc lsp: {message}", file=sys.stderr)
        self.window_log_message(types.LogMessageParams(types.MessageType.Error, message))

    # diagnostics ---------------------------------------------------------------------------------
    def publish(self, document: Document) -> None:
        from rapid_dsl.frontend.driver import check_text

        problem = _too_large(document)
        if problem is not None:
            diagnostics = report.too_large(problem)
        else:
            document.checked = check_text(document.text, document.path, lint=self.lint,
                                          allowed_dirs=self.allowed_dirs)
            if parses(document.text, document.path):
                document.parses()
            _release(document)
            diagnostics = report.to_lsp(document.checked, document.path,
                                        document.lines(self.encoding), self.documents.uri_of)
        self.text_document_publish_diagnostics(types.PublishDiagnosticsParams(
            document.uri, diagnostics, version=document.version))

    def publish_soon(self, document: Document) -> None:
        self.cancel(document.uri)

        def due() -> None:
            self.pending.pop(document.uri, None)
            if self.documents.get(document.uri) is document:
                self.guard(self.publish, None)(document)

        self.pending[document.uri] = asyncio.get_running_loop().call_later(DEBOUNCE_S, due)

    def cancel(self, uri: str) -> None:
        timer = self.pending.pop(uri, None)
        if timer is not None:
            timer.cancel()

    # the model -----------------------------------------------------------------------------------
    def model(self, document: Document) -> Model | None:
        if _too_large(document) is not None:
            return None
        if document.model is None:
            document.model = build(document.text, document.path, self.allowed_dirs)
            if document.model.module is not None:
                document.parses()
                document.parsed_model = document.model
            _release(document)
        return document.model

    def names_model(self, document: Document) -> Model | None:
        """The model to take names from: this version's, or while it does not parse, that of
        the newest version that did."""
        model = self.model(document)
        if model is None or model.module is not None or document.parsed is None:
            return model
        if document.parsed_model is None:
            document.parsed_model = build(document.parsed, document.path, self.allowed_dirs)
        return document.parsed_model

    def guard(self, handler: Callable[..., T], default: T) -> Callable[..., T]:
        """`handler`, answering `default` (and logging) when it raises."""
        @functools.wraps(handler)
        def guarded(*args: Any) -> T:
            try:
                return handler(*args)
            except Exception as exc:  # noqa: BLE001 - a bug must not stop the server
                message = (f"internal error: {type(exc).__name__}: {exc} (a bug in rapidc, not "
                           "in your program; please report it; set RAPIDC_DEBUG=1 to see the "
                           "traceback)")
                if os.environ.get("RAPIDC_DEBUG"):
                    message += "\n" + traceback.format_exc()
                self.log(message)
                return default
        return guarded


def _release(document: Document) -> None:
    """The parser keeps the trees of the last 64 texts it read (parser.py), one per version of a
    document being edited: for a large one (20,000 lines: 34 MB each) that would grow to
    gigabytes, so after reading one the cache is dropped (the stdlib is parsed again, ~10 ms)."""
    if len(document.text) > LARGE_TEXT:
        from rapid_dsl.frontend.parser import forget_parsed

        forget_parsed()


def _too_large(document: Document) -> str | None:
    size = len(document.text.encode("utf-8", "surrogatepass"))
    if size <= MAX_INPUT_BYTES:
        return None
    return (f"not checked: the text is larger than the input limit of "
            f"{MAX_INPUT_BYTES // (1024 * 1024)} MiB")


def create_server(allowed_dirs: Sequence[str] = ()) -> RapidServer:
    server = RapidServer(allowed_dirs)

    def feature(name: str, options: Any = None, default: Any = None) -> Callable[..., Any]:
        def register(handler: Callable[..., Any]) -> Callable[..., Any]:
            server.feature(name, options)(server.guard(handler, default))
            return handler
        return register

    @feature(types.INITIALIZE)
    def initialize(ls: RapidServer, params: types.InitializeParams) -> None:
        options = params.initialization_options
        if isinstance(options, dict) and isinstance(options.get("lint"), bool):
            ls.lint = options["lint"]

    @feature(types.SHUTDOWN)
    def shutdown(ls: RapidServer, params: Any) -> None:
        ls.shutdown_requested = True
        for uri in list(ls.pending):
            ls.cancel(uri)

    @feature(types.TEXT_DOCUMENT_DID_OPEN)
    def did_open(ls: RapidServer, params: types.DidOpenTextDocumentParams) -> None:
        item = params.text_document
        ls.publish(ls.documents.add(item.uri, item.version, item.text, item.language_id))

    @feature(types.TEXT_DOCUMENT_DID_CHANGE)
    def did_change(ls: RapidServer, params: types.DidChangeTextDocumentParams) -> None:
        document = ls.documents.get(params.text_document.uri)
        if document is None:
            return
        text = document.text
        for change in params.content_changes:
            change_range = getattr(change, "range", None)
            text = Text(text, ls.encoding).apply(change_range, change.text)
        document.update(params.text_document.version, text)
        ls.publish_soon(document)

    @feature(types.TEXT_DOCUMENT_DID_CLOSE)
    def did_close(ls: RapidServer, params: types.DidCloseTextDocumentParams) -> None:
        uri = params.text_document.uri
        ls.cancel(uri)
        ls.documents.close(uri)
        ls.text_document_publish_diagnostics(types.PublishDiagnosticsParams(uri, []))

    @feature(types.TEXT_DOCUMENT_DID_SAVE)
    def did_save(ls: RapidServer, params: types.DidSaveTextDocumentParams) -> None:
        """The other open documents read what they `use` from disk, and the saved file may be one
        of them (or one a `use` could not find before): check them again."""
        uri = params.text_document.uri
        for document in list(ls.documents.open.values()):
            if document.uri != uri:
                ls.cancel(document.uri)
                document.model = document.parsed_model = None
                ls.publish(document)

    @feature(types.TEXT_DOCUMENT_HOVER)
    def on_hover(ls: RapidServer, params: types.HoverParams) -> types.Hover | None:
        document = ls.documents.get(params.text_document.uri)
        model = ls.model(document) if document is not None else None
        if document is None or model is None:
            return None
        lines = document.lines(ls.encoding)
        line, col = lines.location(params.position)
        found = hover(model, line, col)
        if found is None:
            return None
        content, span = found
        return types.Hover(types.MarkupContent(types.MarkupKind.Markdown, content),
                           lines.range(span))

    @feature(types.TEXT_DOCUMENT_DEFINITION)
    def on_definition(ls: RapidServer, params: types.DefinitionParams) -> types.Location | None:
        document = ls.documents.get(params.text_document.uri)
        model = ls.model(document) if document is not None else None
        if document is None or model is None:
            return None
        line, col = document.lines(ls.encoding).location(params.position)
        target = definition(model, line, col)
        if target is None:
            return None
        if target.path == document.path:
            return types.Location(document.uri, document.lines(ls.encoding).range(target.span))
        file = model.file(target.path)
        uri = ls.documents.uri_of(file.location) if file and file.location else None
        if file is None or uri is None:
            return None
        return types.Location(uri, Text(file.text, ls.encoding).range(target.span))

    @feature(types.TEXT_DOCUMENT_COMPLETION,
             types.CompletionOptions(trigger_characters=[".", "(", ",", "{", ":"]))
    def on_completion(ls: RapidServer, params: types.CompletionParams
                      ) -> types.CompletionList | None:
        document = ls.documents.get(params.text_document.uri)
        if document is None:
            return None
        model = ls.names_model(document)
        lines = document.lines(ls.encoding)
        line, col = lines.location(params.position)
        before = lines.text[lines.starts[line - 1]:lines.offset(params.position)]
        if line == 1:
            before = before.removeprefix("\ufeff")
        items = complete(model, before, line, col, yaml=document.is_yaml)
        return types.CompletionList(is_incomplete=False, items=items)

    @feature(types.TEXT_DOCUMENT_FORMATTING)
    def on_formatting(ls: RapidServer, params: types.DocumentFormattingParams
                      ) -> list[types.TextEdit] | None:
        """As `rapidc fmt --write`: `.rapid` documents only (a YAML program would be replaced by
        its `.rapid` text); nothing while the text has syntax errors."""
        from rapid_dsl.frontend.formatter import format_source

        document = ls.documents.get(params.text_document.uri)
        if document is None or document.is_yaml or _too_large(document) is not None:
            return None
        formatted, _ = format_source(document.text, document.path)
        if formatted is None or formatted == document.text:
            return []
        lines = document.lines(ls.encoding)
        whole = types.Range(types.Position(0, 0), lines.end())
        return [types.TextEdit(whole, formatted)]

    return server


def _warm_up() -> None:
    """Check a program that uses the whole standard library, before the first document arrives
    rather than while it waits: the checker and lint load, and the parser caches the stdlib."""
    from rapid_dsl.frontend.driver import check_text
    from rapid_dsl.frontend.modules import Stdlib

    names = Stdlib().names()
    try:
        if names:
            check_text(f"use stdlib.{{{', '.join(names)}}}\n", os.path.abspath("warm-up.rapid"),
                       lint=True)
    except OSError:   # no working folder (it was removed): the first document warms up instead
        pass


def serve(allowed_dirs: Sequence[str] = ()) -> int:
    """Run the server on standard input and output until the client says `exit`; the exit status
    is 0 after a `shutdown` request, else 1 (as the protocol says)."""
    _warm_up()
    server = create_server(allowed_dirs)
    if sys.stdin.isatty():
        print("rapidc lsp: a language server; it talks LSP on standard input and output, "
              "for an editor to start (docs/editors.md)", file=sys.stderr)
    # The protocol gets copies of the standard streams, which pygls closes at `exit`; anything
    # else that would print to standard output goes to standard error instead of into it.
    stdin = os.fdopen(os.dup(sys.stdin.fileno()), "rb")
    stdout = os.fdopen(os.dup(sys.stdout.fileno()), "wb")
    try:
        with contextlib.redirect_stdout(sys.stderr):
            server.start_io(stdin, stdout)
    finally:
        server.documents.dispose()
        for stream in (stdin, stdout):
            with contextlib.suppress(OSError):
                stream.close()
    return 0 if server.shutdown_requested else 1
