"""`rapidc lsp`: the language server, over standard input and output, built on pygls.

Diagnostics are the checker's (`driver.check_text`, with lint warnings unless the client's
initialization options say `{"lint": false}`), published when a document opens and shortly after
each change; hover, go to definition, completion and formatting read the document's typed model
(model.py), built once per version when one of them asks. Checks and models are made in worker
threads (work.py), so a large document holds up no request about another. The server keeps its
own copy of each document (documents.py) and converts every position in positions.py. Frames are
read by loop.py, which answers every request, whatever the client sends.

Every handler catches what it does not expect: a bug answers one request with nothing and is
logged, and the server goes on. A request it cannot answer (a position that is not one, a URI that
names no file) gets a JSON-RPC error.
"""

from __future__ import annotations

import asyncio
import contextlib
import functools
import inspect
import logging
import os
import sys
import traceback
from collections.abc import Callable, Coroutine, Sequence
from typing import Any, BinaryIO, TypeVar

from lsprotocol import types
from pygls.exceptions import JsonRpcContentModified, JsonRpcException, JsonRpcInvalidParams
from pygls.lsp.server import LanguageServer

from rapid_dsl import __version__
from rapid_dsl.frontend.driver import deep_recursion
from rapid_dsl.language.files import MAX_INPUT_BYTES
from rapid_dsl.lsp import loop, report
from rapid_dsl.lsp.completion import complete
from rapid_dsl.lsp.definition import definition
from rapid_dsl.lsp.documents import BadUri, Document, Documents, file_path
from rapid_dsl.lsp.hover import hover
from rapid_dsl.lsp.model import Model, build, parses
from rapid_dsl.lsp.positions import ENCODINGS, UTF16, Text
from rapid_dsl.lsp.work import Work

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
        self.work = Work()
        self.tasks: set[asyncio.Task[None]] = set()

    @property
    def encoding(self) -> str:
        agreed = self.workspace.position_encoding
        value = str(getattr(agreed, "value", agreed) or UTF16)
        return value if value in ENCODINGS else UTF16

    def log(self, message: str, kind: types.MessageType = types.MessageType.Error) -> None:
        print(f"rapidc lsp: {message}", file=sys.stderr)
        self.window_log_message(types.LogMessageParams(kind, message))

    def start_io(self, stdin: BinaryIO | None = None, stdout: BinaryIO | None = None) -> None:
        """Serve until `exit` or the end of input, frames read by loop.py, not pygls."""
        loop.start(self, stdin or sys.stdin.buffer, stdout or sys.stdout.buffer)

    def document(self, uri: str) -> Document | None:
        """The open document of `uri`, None if it is not open; a URI that names no file is an
        error of the request (invalid params)."""
        found = self.documents.get(uri)
        if found is None:
            try:
                file_path(uri)
            except BadUri as exc:
                raise JsonRpcInvalidParams(str(exc)) from None
        return found

    # diagnostics ---------------------------------------------------------------------------------
    async def publish(self, document: Document) -> None:
        """Check the document as it is now (in a worker thread) and publish the diagnostics,
        unless it changed or closed meanwhile (a newer check publishes)."""
        from rapid_dsl.frontend.driver import check_text

        revision, text, path, uri = document.revision, document.text, document.path, document.uri
        problem = _too_large(document)
        if problem is not None:
            self._send_diagnostics(document, report.not_checked(problem))
            return
        lines, lint, allowed, uri_of = (document.lines(self.encoding), self.lint,
                                        self.allowed_dirs, self.documents.uri_finder())

        def check() -> tuple[Any, bool, list[types.Diagnostic]]:
            checked = check_text(text, path, lint=lint, allowed_dirs=allowed)
            parsed = parses(text, path)
            _release(text)
            return checked, parsed, report.to_lsp(checked, path, lines, uri_of)

        def stale() -> bool:
            return document.revision != revision or self.documents.get(uri) is not document

        done = await self.work.run(f"check {uri}", check, stale)
        if done is None or stale():
            return
        document.checked, parsed, diagnostics = done
        if parsed:
            document.parses()
        self._send_diagnostics(document, diagnostics)

    def _send_diagnostics(self, document: Document, diagnostics: list[types.Diagnostic]) -> None:
        self.text_document_publish_diagnostics(types.PublishDiagnosticsParams(
            document.uri, diagnostics, version=document.version))

    def publish_soon(self, document: Document) -> None:
        self.cancel(document.uri)

        def due() -> None:
            self.pending.pop(document.uri, None)
            if self.documents.get(document.uri) is document:
                self.start(self.publish(document))

        self.pending[document.uri] = asyncio.get_running_loop().call_later(DEBOUNCE_S, due)

    def start(self, work: Coroutine[Any, Any, None]) -> None:
        """Run `work` as a task of its own (kept until it ends; a bug in it is logged)."""
        async def guarded() -> None:
            try:
                await work
            except Exception as exc:  # noqa: BLE001 - a bug must not stop the server
                self.bug(exc)

        task = asyncio.ensure_future(guarded())
        self.tasks.add(task)
        task.add_done_callback(self.tasks.discard)

    def cancel(self, uri: str) -> None:
        timer = self.pending.pop(uri, None)
        if timer is not None:
            timer.cancel()

    # the model -----------------------------------------------------------------------------------
    async def model(self, document: Document) -> Model | None:
        """The model of the document as it is now, built in a worker thread. ContentModified if
        the document changed before the build began (the request was about the old text)."""
        if _too_large(document) is not None:
            return None
        revision, text, path = document.revision, document.text, document.path
        allowed = self.allowed_dirs

        def make() -> Model:
            model = build(text, path, allowed)
            _release(text)
            return model

        def stale() -> bool:
            return document.revision != revision or document.model is not None

        made = await self.work.run(f"model {document.uri}", make, stale)
        if document.revision == revision:
            if made is not None:
                document.model = made
                if made.module is not None:
                    document.parses()
                    document.parsed_model = made
            return document.model
        if made is None:
            raise JsonRpcContentModified("the document changed; ask again")
        return made

    async def names_model(self, document: Document) -> Model | None:
        """The model to take names from: this version's, or while it does not parse, that of
        the newest version that did."""
        model = await self.model(document)
        if model is None or model.module is not None or document.parsed is None:
            return model
        parsed, path, allowed = document.parsed, document.path, self.allowed_dirs
        if document.parsed_model is None:
            made = await self.work.run(f"names {document.uri}",
                                       lambda: build(parsed, path, allowed),
                                       lambda: document.parsed is not parsed
                                       or document.parsed_model is not None)
            if made is not None and document.parsed is parsed:
                document.parsed_model = made
        return document.parsed_model or model

    def guard(self, handler: Callable[..., Any], default: Any) -> Callable[..., Any]:
        """`handler` (a function or a coroutine function), answering `default` (and logging)
        when it raises; a JSON-RPC error it raises on purpose is the request's answer."""
        if inspect.iscoroutinefunction(handler):
            @functools.wraps(handler)
            async def guarded_async(*args: Any) -> Any:
                try:
                    return await handler(*args)
                except JsonRpcException:
                    raise
                except Exception as exc:  # noqa: BLE001 - a bug must not stop the server
                    self.bug(exc)
                    return default
            return guarded_async

        @functools.wraps(handler)
        def guarded(*args: Any) -> Any:
            try:
                return handler(*args)
            except JsonRpcException:
                raise
            except Exception as exc:  # noqa: BLE001 - a bug must not stop the server
                self.bug(exc)
                return default
        return guarded

    def bug(self, exc: Exception) -> None:
        message = (f"internal error: {type(exc).__name__}: {exc} (a bug in rapidc, not in your "
                   "program; please report it; set RAPIDC_DEBUG=1 to see the traceback)")
        if os.environ.get("RAPIDC_DEBUG"):
            message += "\n" + "".join(traceback.format_exception(exc))
        self.log(message)


def _release(text: str) -> None:
    """The parser keeps the trees of the last 64 texts it read (parser.py), one per version of a
    document being edited: for a large one (20,000 lines: 34 MB each) that would grow to
    gigabytes, so after reading one the cache is dropped (the stdlib is parsed again, ~10 ms)."""
    if len(text) > LARGE_TEXT:
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
        try:
            document = ls.documents.add(item.uri, item.version, item.text, item.language_id)
        except BadUri as exc:   # a notification has no answer: say so where the editor shows it
            ls.log(f"not opened: {exc}", types.MessageType.Warning)
            ls.text_document_publish_diagnostics(types.PublishDiagnosticsParams(
                item.uri, report.not_checked(f"not checked: {exc}"), version=item.version))
            return
        ls.start(ls.publish(document))

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
                document.forget()
                ls.start(ls.publish(document))

    @feature(types.TEXT_DOCUMENT_HOVER)
    async def on_hover(ls: RapidServer, params: types.HoverParams) -> types.Hover | None:
        document = ls.document(params.text_document.uri)
        if document is None:
            return None
        lines = document.lines(ls.encoding)     # of the text the request is about
        model = await ls.model(document)
        if model is None:
            return None
        line, col = lines.location(params.position)
        found = hover(model, line, col)
        if found is None:
            return None
        content, span = found
        return types.Hover(types.MarkupContent(types.MarkupKind.Markdown, content),
                           lines.range(span))

    @feature(types.TEXT_DOCUMENT_DEFINITION)
    async def on_definition(ls: RapidServer, params: types.DefinitionParams
                            ) -> types.Location | None:
        document = ls.document(params.text_document.uri)
        if document is None:
            return None
        uri, path, lines = document.uri, document.path, document.lines(ls.encoding)
        model = await ls.model(document)
        if model is None:
            return None
        line, col = lines.location(params.position)
        target = definition(model, line, col)
        if target is None:
            return None
        if target.path == path:
            return types.Location(uri, lines.range(target.span))
        file = model.file(target.path)
        found = ls.documents.uri_of(file.location) if file and file.location else None
        if file is None or found is None:
            return None
        return types.Location(found, Text(file.text, ls.encoding).range(target.span))

    @feature(types.TEXT_DOCUMENT_COMPLETION,
             types.CompletionOptions(trigger_characters=[".", "(", ",", "{", ":"]))
    async def on_completion(ls: RapidServer, params: types.CompletionParams
                            ) -> types.CompletionList | None:
        document = ls.document(params.text_document.uri)
        if document is None:
            return None
        lines, is_yaml = document.lines(ls.encoding), document.is_yaml
        model = await ls.names_model(document)
        line, col = lines.location(params.position)
        before = lines.text[lines.starts[line - 1]:lines.offset(params.position)]
        if line == 1:
            before = before.removeprefix("\ufeff")
        items = complete(model, before, line, col, yaml=is_yaml)
        return types.CompletionList(is_incomplete=False, items=items)

    @feature(types.TEXT_DOCUMENT_FORMATTING)
    async def on_formatting(ls: RapidServer, params: types.DocumentFormattingParams
                            ) -> list[types.TextEdit] | None:
        """As `rapidc fmt --write`: `.rapid` documents only (a YAML program would be replaced by
        its `.rapid` text); nothing while the text has syntax errors."""
        from rapid_dsl.frontend.formatter import format_source

        document = ls.document(params.text_document.uri)
        if document is None or document.is_yaml or _too_large(document) is not None:
            return None
        revision, text, path = document.revision, document.text, document.path
        lines = document.lines(ls.encoding)
        done = await ls.work.run(f"format {document.uri} {revision}",
                                 lambda: format_source(text, path), lambda: False)
        assert done is not None
        formatted, _ = done
        if formatted is None or formatted == text:
            return []
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
    logging.getLogger("pygls").addHandler(logging.NullHandler())   # loop.py reports instead
    if sys.stdin.isatty():
        print("rapidc lsp: a language server; it talks LSP on standard input and output, "
              "for an editor to start (docs/editors.md)", file=sys.stderr)
    # The protocol gets copies of the standard streams, which pygls closes at `exit`; anything
    # else that would print to standard output goes to standard error instead of into it.
    stdin = os.fdopen(os.dup(sys.stdin.fileno()), "rb")
    stdout = os.fdopen(os.dup(sys.stdout.fileno()), "wb")
    try:
        # checks run in several threads: the recursion limit each raises while it runs is
        # raised for the whole server, so none lowers it under another
        with contextlib.redirect_stdout(sys.stderr), deep_recursion():
            server.start_io(stdin, stdout)
    finally:
        server.work.stop()
        server.documents.dispose()
        for stream in (stdin, stdout):
            with contextlib.suppress(OSError):
                stream.close()
    return 0 if server.shutdown_requested else 1
