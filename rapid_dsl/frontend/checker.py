"""The type checker: a resolved module graph -> ir.Program, with every error of every file.

Order: the signatures of all `def`s and relations, then their bodies (and recursion), then the
primitives, then the strategies (which read the primitives' checked roles, params and
requirements). Each declaration is checked once, in the scope of the file that declares it, and
its diagnostics carry that file's path. The details live in rapid_dsl/frontend/check/.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field
from functools import partial

from rapid_dsl.frontend import ir
from rapid_dsl.frontend import syntax as ast
from rapid_dsl.frontend.check.common import Names
from rapid_dsl.frontend.check.expressions import ExprChecker, is_error
from rapid_dsl.frontend.check.primitives import PrimitiveChecker, PrimitiveInfo
from rapid_dsl.frontend.check.scope import Env, FuncSig, Globals, Local
from rapid_dsl.frontend.check.signatures import fixed_sig, resolve_type
from rapid_dsl.frontend.check.strategies import StrategyChecker
from rapid_dsl.frontend.modules import Entry, ModuleGraph, Named, SourceFile
from rapid_dsl.frontend.tree import walk
from rapid_dsl.frontend.types import BOOL, Type, assignable
from rapid_dsl.language.diagnostics import Diagnostic, error
from rapid_dsl.language.registry import BUILTINS

__all__ = ["check_program"]


@dataclass(eq=False)
class _Checker:
    graph: ModuleGraph
    diagnostics: list[Diagnostic] = field(default_factory=list)
    ir_names: dict[int, str] = field(default_factory=dict)         # id(decl) -> unique IR name
    signatures: dict[int, FuncSig | None] = field(default_factory=dict)
    functions: dict[int, ir.Function] = field(default_factory=dict)
    primitives: dict[int, PrimitiveInfo | None] = field(default_factory=dict)
    strategies: dict[int, ir.Strategy] = field(default_factory=dict)
    globals: dict[str, Globals] = field(default_factory=dict)       # file key -> its top level
    owner: dict[int, SourceFile] = field(default_factory=dict)      # id(decl) -> its file
    decls: dict[int, Named] = field(default_factory=dict)           # id(decl) -> decl

    def run(self) -> ir.Program:
        self.name_declarations()
        for file in self.graph.files:
            self.globals[file.key] = Globals(self.graph.scope(file), self.signature,
                                             file.incomplete)
        decls = [(self.owner[k], d) for k, d in self.decls.items()]
        for _, d in decls:
            if isinstance(d, (ast.RelationDecl, ast.DefDecl)):
                self.signature_of(d)
        for file, d in decls:
            if isinstance(d, (ast.RelationDecl, ast.DefDecl)):
                self.guarded(d, partial(self.function, d, file))
        self.recursion()
        for _, d in decls:
            if isinstance(d, ast.Primitive):
                self.guarded(d, partial(self.primitive_info, d))
        for file, d in decls:
            if isinstance(d, ast.Strategy):
                self.guarded(d, partial(self.strategy, d, file))
        return self.program()

    def guarded(self, decl: Named, work: Callable[[], object]) -> None:
        """Run one declaration's check; a program nested too deeply gets a diagnostic."""
        try:
            work()
        except RecursionError:
            name = decl.name
            self.diagnostics.append(error(
                "E0409", f"`{name.name}` is nested too deeply to check", name.span,
                help="split long expressions with `let` or resolve entries"))

    # names ----------------------------------------------------------------------------------------
    def name_declarations(self) -> None:
        """Unique IR names: the root file keeps its names; clashes elsewhere get a suffix.

        Builtins are not among the taken names: calls of builtins and of user functions are
        different IR nodes, so a `def` named like a builtin (W0109) needs no renaming."""
        taken: set[str] = set()
        suffix: dict[str, int] = {}     # name -> the next suffix to try (n clashes stay O(n))
        for file in self.graph.files:
            for d in file.module.decls if file.module else ():
                if isinstance(d, ast.Use):
                    continue
                name = d.name.name
                candidate, n = name, suffix.get(name, 2)
                while candidate in taken:
                    candidate, n = f"{name}_{n}", n + 1
                suffix[name] = n
                taken.add(candidate)
                self.ir_names[id(d)] = candidate
                self.owner[id(d)] = file
                self.decls[id(d)] = d

    # functions ------------------------------------------------------------------------------------
    def signature(self, entry: Entry) -> FuncSig | None:
        return self.signatures.get(id(entry.decl))

    def signature_of(self, d: ast.RelationDecl | ast.DefDecl) -> None:
        local: list[Diagnostic] = []
        params = []
        for p in d.params:
            params.append((p.name.name, resolve_type(p.type, local)))
        returns: Type = BOOL if isinstance(d, ast.RelationDecl) else resolve_type(d.returns, local)
        self.diagnostics.extend(local)
        sigs = [(n, fixed_sig(t)) for n, t in params]
        ret = fixed_sig(returns)
        if local or ret is None or any(s is None for _, s in sigs):
            self.signatures[id(d)] = None
            return
        self.signatures[id(d)] = FuncSig(self.ir_names[id(d)],
                                         tuple((n, s) for n, s in sigs if s is not None), ret,
                                         isinstance(d, ast.RelationDecl))

    def function(self, d: ast.RelationDecl | ast.DefDecl, file: SourceFile) -> None:
        names = Names(self.diagnostics)
        locals_ = []
        for p in d.params:
            t = resolve_type(p.type, [])
            if names.declare(p.name, "parameter"):
                locals_.append(Local("local", p.name.name, t, p.name.span))
        env = Env(self.globals[file.key]).with_locals(*locals_)
        exprs = ExprChecker(file.text, self.diagnostics)
        body = exprs.check(d.body, env)
        if isinstance(d, ast.RelationDecl):
            returns: Type = BOOL
            if not is_error(body.type) and body.type != BOOL:
                exprs.err("E0307", f"the body of relation `{d.name.name}` must be Bool, "
                          f"got {body.type}", d.body.span, help="relations are conditions, e.g. "
                          "`distance(a, b) < 5cm`; use `def` for values")
        else:
            returns = resolve_type(d.returns, [])
            if not is_error(body.type) and not is_error(returns) and \
                    not assignable(body.type, returns):
                exprs.err("E0313", f"`{d.name.name}` returns {returns} but its body is "
                          f"{body.type}", d.body.span)
        sig = self.signatures.get(id(d))
        self.functions[id(d)] = ir.Function(
            self.ir_names[id(d)], tuple((lo.name, lo.type) for lo in locals_), returns, body,
            isinstance(d, ast.RelationDecl), d.span)
        if sig is not None:
            sig.symbolic = all(not (isinstance(n, ir.BuiltinCall) and n.name in BUILTINS
                                    and not BUILTINS[n.name].symbolic) for n in walk(body))

    def recursion(self) -> None:
        """Report each `def`/relation that can reach itself through calls (O(calls): one
        strongly-connected-component pass), then mark callers of non-symbolic functions."""
        decl_of = {f.name: k for k, f in self.functions.items()}
        calls = {f.name: sorted({n.name for n in walk(f.body) if isinstance(n, ir.UserCall)
                                 and n.name in decl_of}) for f in self.functions.values()}
        for name, path in _cycles(calls).items():
            decl = self.decls[decl_of[name]]
            shown = path if len(path) <= 12 else [*path[:6], "...", *path[-5:]]
            self.diagnostics.append(error(
                "E0214", f"`{name}` calls itself: {' -> '.join(shown)}", decl.name.span,
                help="relations and defs cannot be recursive"))
        # Symbolic use goes through callees too: a caller is symbolic only if its callees are.
        callers: dict[str, list[str]] = {name: [] for name in calls}
        for name, callees in calls.items():
            for callee in callees:
                callers[callee].append(name)
        plain = [name for name in calls if not self.symbolic(name, decl_of)]
        while plain:
            for caller in callers[plain.pop()]:
                sig = self.signatures.get(decl_of[caller])
                if sig is not None and sig.symbolic:
                    sig.symbolic = False
                    plain.append(caller)

    def symbolic(self, name: str, decl_of: dict[str, int]) -> bool:
        sig = self.signatures.get(decl_of[name])
        return sig is None or sig.symbolic

    # primitives and strategies --------------------------------------------------------------------
    def primitive_entry(self, entry: Entry) -> PrimitiveInfo | None:
        assert isinstance(entry.decl, ast.Primitive)
        return self.primitive_info(entry.decl)

    def primitive_info(self, d: ast.Primitive) -> PrimitiveInfo | None:
        if id(d) not in self.primitives:
            self.primitives[id(d)] = None  # guards against re-entry
            file = self.owner[id(d)]
            checker = PrimitiveChecker(d, self.ir_names[id(d)], file.text, file.path,
                                       self.globals[file.key], self.diagnostics)
            self.primitives[id(d)] = checker.check()
        return self.primitives[id(d)]

    def strategy(self, d: ast.Strategy, file: SourceFile) -> None:
        checker = StrategyChecker(d, self.ir_names[id(d)], file.text, file.path,
                                  self.globals[file.key], self.primitive_entry, self.diagnostics)
        self.strategies[id(d)] = checker.check()

    def program(self) -> ir.Program:
        functions = tuple(self.functions.values())
        primitives = tuple(info.ir for info in self.primitives.values() if info is not None)
        strategies = tuple(self.strategies.values())
        root = self.graph.root
        own = tuple(d.name.name for d in (root.module.decls if root.module else ())
                    if not isinstance(d, ast.Use))
        return ir.Program(root.path, functions, primitives, strategies, own)


def _cycles(calls: dict[str, list[str]]) -> dict[str, list[str]]:
    """Each function on a call cycle -> a path from it back to itself.

    Tarjan's strongly connected components, without recursion (call chains may be long). A
    function that calls itself gets `f -> f`; any other member of a component gets the path to
    the component's first member and back, each part a shortest path inside the component.
    """
    index: dict[str, int] = {}
    low: dict[str, int] = {}
    stack: list[str] = []
    on_stack: set[str] = set()
    components: list[list[str]] = []
    for root in calls:
        if root in index:
            continue
        work = [(root, 0)]
        while work:
            name, i = work.pop()
            if i == 0:
                index[name] = low[name] = len(index)
                stack.append(name)
                on_stack.add(name)
            callees = calls[name]
            if i < len(callees):
                work.append((name, i + 1))
                callee = callees[i]
                if callee not in index:
                    work.append((callee, 0))
                elif callee in on_stack:
                    low[name] = min(low[name], index[callee])
                continue
            if low[name] == index[name]:
                component = []
                while True:
                    member = stack.pop()
                    on_stack.discard(member)
                    component.append(member)
                    if member == name:
                        break
                components.append(component)
            if work:
                parent = work[-1][0]
                low[parent] = min(low[parent], low[name])
    out: dict[str, list[str]] = {}
    for component in components:
        members = set(component)
        if len(component) == 1:
            name = component[0]
            if name in calls[name]:
                out[name] = [name, name]
            continue
        first = min(component, key=index.__getitem__)
        there = _shortest_paths(first, calls, members, forward=True)     # first -> member
        back = _shortest_paths(first, calls, members, forward=False)     # member -> first
        for name in component:
            if name in calls[name]:
                out[name] = [name, name]
            elif name == first:
                out[name] = [first, *back[next(c for c in calls[first] if c in members)]]
            else:
                out[name] = back[name][:-1] + there[name]
    return out


def _shortest_paths(start: str, calls: dict[str, list[str]], members: set[str], *,
                    forward: bool) -> dict[str, list[str]]:
    """Breadth first inside `members`: each member -> the path start -> member (forward) or
    member -> start (backward)."""
    if forward:
        edges = calls
    else:
        edges = {m: [] for m in members}
        for m in members:
            for callee in calls[m]:
                if callee in members:
                    edges[callee].append(m)
    parent: dict[str, str | None] = {start: None}
    queue = [start]
    for name in queue:
        for nxt in edges[name]:
            if nxt in members and nxt not in parent:
                parent[nxt] = name
                queue.append(nxt)
    paths: dict[str, list[str]] = {}
    for name in members:
        path: list[str] = []
        at: str | None = name
        while at is not None:
            path.append(at)
            at = parent[at]
        paths[name] = path[::-1] if forward else path
    return paths


def check_program(graph: ModuleGraph) -> tuple[ir.Program, list[Diagnostic]]:
    """Check every declaration reachable from the graph's root.

    The program is complete only when no diagnostic is an error; the driver discards it otherwise.
    """
    checker = _Checker(graph)
    program = checker.run()
    return program, checker.diagnostics

