"""Lint: warnings (W01xx) about programs that check but are probably not what was meant.

Runs on a checked `ir.Program` and looks only at the declarations of the root file (not at what
`use` brings in).
"""

from __future__ import annotations

from collections.abc import Iterable

from rapid_dsl.frontend import ir
from rapid_dsl.frontend import syntax as ast
from rapid_dsl.frontend.check.strategies import conjuncts, substitute_roles
from rapid_dsl.frontend.check.text import listing, snippet
from rapid_dsl.frontend.modules import ModuleGraph
from rapid_dsl.frontend.tree import walk
from rapid_dsl.language.diagnostics import Diagnostic, Span, warning
from rapid_dsl.language.kinds import KIND_PARENTS, is_subkind
from rapid_dsl.language.registry import BUILTINS

__all__ = ["lint_program"]

# Builtins that read the scene: a cost term reaches one of them or it is the same for every sample.
_SCENE_BUILTINS = frozenset(name for name, b in BUILTINS.items()
                            if any(p.type in KIND_PARENTS for p in b.params))


def lint_program(program: ir.Program, graph: ModuleGraph) -> list[Diagnostic]:
    text = graph.root.text
    functions = {f.name: f for f in program.functions}
    out: list[Diagnostic] = _shadowed_builtins(graph)
    for primitive in program.primitives:
        if primitive.path == program.path and primitive.name in program.own:
            out.extend(_PrimitiveLint(primitive, functions, text).run())
    primitives = {p.name: p for p in program.primitives}
    for strategy in program.strategies:
        if strategy.path == program.path and strategy.name in program.own:
            out.extend(_strategy(strategy, primitives, text))
    return out


def _shadowed_builtins(graph: ModuleGraph) -> list[Diagnostic]:
    """W0109: a `def` or relation of the file named like a builtin. Allowed (a builtin added
    later must not break programs), and the file's own declaration wins in its calls."""
    out: list[Diagnostic] = []
    module = graph.root.module
    for decl in module.decls if module else ():
        if not isinstance(decl, (ast.DefDecl, ast.RelationDecl)) or decl.name.name not in BUILTINS:
            continue
        name, builtin = decl.name.name, BUILTINS[decl.name.name]
        what = "def" if isinstance(decl, ast.DefDecl) else "relation"
        if builtin.kind == "constant":
            message = f"{what} `{name}` has the name of the builtin constant `{name}`"
            help_text = f"`{name}` alone is still the constant; rename the {what}"
        else:
            message = f"{what} `{name}` hides the builtin `{builtin.signature}` in this file"
            help_text = f"`{name}(...)` here calls this {what}; rename it to keep the builtin"
        out.append(warning("W0109", message, decl.name.span, help=help_text))
    return out


def _name_span(span: Span, name: str) -> Span:
    """The leading name of a declaration (`angle` of `angle: Angle in [...]`)."""
    return Span(span.path, span.start, span.start + len(name), span.line, span.col, span.line,
                span.col + len(name))


def _refs(exprs: Iterable[ir.Expr | ir.Solve | None], kind: str) -> set[str]:
    return {n.name for e in exprs if e is not None for n in walk(e)
            if isinstance(n, ir.Ref) and n.kind == kind}


class _PrimitiveLint:
    def __init__(self, p: ir.Primitive, functions: dict[str, ir.Function], text: str) -> None:
        self.p = p
        self.functions = functions
        self.text = text
        self.features = {f.name: f for f in p.features}
        self.scans: dict[tuple[str, str], tuple[bool, list[tuple[str, str]]]] = {}
        self.scene: dict[tuple[str, str], bool] = {}   # feature or function -> reads the scene

    def through_features(self, exprs: Iterable[ir.Expr | None]) -> list[ir.Expr]:
        """`exprs` and the expressions of every feature they read, transitively."""
        out = [e for e in exprs if e is not None]
        seen: set[str] = set()
        i = 0
        while i < len(out):
            for name in _refs([out[i]], "feature") - seen:
                seen.add(name)
                out.append(self.features[name].expr)
            i += 1
        return out

    def run(self) -> list[Diagnostic]:
        p = self.p
        out: list[Diagnostic] = []
        clauses = [c.expr for c in (*p.requires, *p.success, *p.filter)]
        keypoint_exprs = [e for k in p.keypoints for e in k.children()]   # point and angles
        everything = [*clauses, *(f.expr for f in p.features), p.cost_final, p.cost_progress,
                      *keypoint_exprs]
        used_roles = _refs(everything, "role")
        used_params = _refs(everything, "param")
        later = [*clauses, p.cost_final, p.cost_progress, *keypoint_exprs]
        for role in p.roles:
            # the motion drives the Manipulator whether or not an expression names it
            if role.name not in used_roles and not is_subkind(role.kind, "Manipulator"):
                out.append(warning("W0101", f"role `{role.name}` is never used",
                                   _name_span(role.span, role.name),
                                   help="remove it, or use it in a clause, cost or keypoint"))
        # A feature can read only earlier ones, so "read by a later feature" is "read by any".
        read = _refs([*later, *(f.expr for f in p.features)], "feature")
        for feature in p.features:
            if feature.name not in read:
                out.append(warning("W0103", f"resolved feature `{feature.name}` is never used",
                                   _name_span(feature.span, feature.name),
                                   help="remove it, or use it in success, a cost or a keypoint"))
        judged = self.through_features([*(c.expr for c in p.success), p.cost_final,
                                        p.cost_progress])
        judged_params = _refs(judged, "param")
        for param in p.params:
            span = _name_span(param.span, param.name)
            if param.name not in used_params:
                out.append(warning("W0102", f"param `{param.name}` is never used", span,
                                   help="a strategy sets it, but nothing reads it"))
            elif param.name not in judged_params:
                out.append(warning(
                    "W0104", f"no success clause or cost mentions param `{param.name}`", span,
                    help="the optimizer cannot tell whether the requested effect happened"))
        success_params = _refs(self.through_features([c.expr for c in p.success]), "param")
        # The effect params are those the final cost judges: a param only `cost progress` reads
        # (grasp's `approach`) shapes the path, not the result. With none read at all,
        # W0102/W0104 already say it.
        effect_params = _refs(self.through_features([p.cost_final]), "param")
        if p.params and p.success and not success_params and effect_params:
            first = p.success[0].span
            names = ", ".join(f"`{q.name}`" for q in p.params)
            out.append(warning(
                "W0107", f"success never reads the effect param{'s' if len(p.params) > 1 else ''} "
                f"{names}", first, help="success should check that the requested effect "
                "happened, e.g. `abs(turned - angle) < 10deg`"))
        for cost in (p.cost_final, p.cost_progress):
            if cost is None:
                continue
            for term in _terms(cost):
                if not self.scene_dependent(term):
                    out.append(warning(
                        "W0106", "this cost term is the same for every motion", term.span,
                        label="does not depend on the scene",
                        help="it cannot guide the optimizer; make it depend on a role (e.g. "
                        "through a resolve entry) or remove it"))
        return out

    def scene_dependent(self, expr: ir.Expr) -> bool:
        reads, needs = self.scan(expr)
        return reads or any(self.named_scene_dependent(key) for key in needs)

    def scan(self, expr: ir.Expr) -> tuple[bool, list[tuple[str, str]]]:
        reads, needs = _scene_reads(expr)
        return reads, [(kind, name) for kind, name in needs
                       if kind == "feature" or name in self.functions]

    def named_scene_dependent(self, key: tuple[str, str]) -> bool:
        """Does the feature or function `key` read the scene? Each is worked out once per
        primitive (a cost of n terms over a chain of m features costs n + m, not n * m),
        without recursion (features chain thousands deep): a name waits on the stack until
        the names it reads are known."""
        known = self.scene
        stack = [key]
        while stack:
            top = stack[-1]
            if top in known:
                stack.pop()
                continue
            if top not in self.scans:
                kind, name = top
                self.scans[top] = self.scan(self.features[name].expr if kind == "feature"
                                            else self.functions[name].body)
            reads, needs = self.scans[top]
            waiting = [n for n in needs if n not in known] if not reads else []
            if waiting:
                stack.extend(waiting)
                continue
            known[top] = reads or any(known[n] for n in needs)
            stack.pop()
        return known[key]


def _scene_reads(expr: ir.Expr) -> tuple[bool, set[tuple[str, str]]]:
    """Does `expr` itself reach a builtin that reads the scene, and which features and
    functions it reads (both outside `start(...)`, fixed at the primitive's start)."""
    needs: set[tuple[str, str]] = set()
    stack: list[ir.Expr] = [expr]
    while stack:
        node = stack.pop()
        match node:
            case ir.Start():
                continue
            case ir.BuiltinCall(name=name) if name in _SCENE_BUILTINS:
                return True, needs
            case ir.Ref(kind="feature", name=name):
                needs.add(("feature", name))
            case ir.UserCall(name=name):
                needs.add(("function", name))
        stack.extend(node.children())  # type: ignore[arg-type]
    return False, needs


def _terms(expr: ir.Expr) -> list[ir.Expr]:
    """The summands of a cost: `a + b - c` -> [a, b, c]."""
    if isinstance(expr, ir.Binary) and expr.op in "+-":
        return [*_terms(expr.left), *_terms(expr.right)]
    return [expr]


def _strategy(s: ir.Strategy, primitives: dict[str, ir.Primitive], text: str
              ) -> list[Diagnostic]:
    out: list[Diagnostic] = []
    exprs: list[ir.Expr | ir.Solve | None] = [
        *(c.expr for c in (*s.requires, *s.success, *s.filter)), *(let.expr for let in s.lets),
        *(a.value for ph in s.phases for a in ph.args)]
    used_roles = _refs(exprs, "role") | {target for ph in s.phases for _, target in ph.role_map}
    for role in s.roles:
        if role.name not in used_roles:
            out.append(warning("W0101", f"role `{role.name}` is never used",
                               _name_span(role.span, role.name),
                               help="remove it, or map it to a role of a phase"))
    used_lets = _refs(exprs, "let")
    for let in s.lets:
        if let.name not in used_lets:
            out.append(warning("W0108", f"`let {let.name}` is never used",
                               _name_span(Span(let.span.path, let.span.start + 4, let.span.end,
                                               let.span.line, let.span.col + 4, let.span.end_line,
                                               let.span.end_col), let.name),
                               help="remove it, or use it in a phase argument"))
    roles = {r.name: r for r in s.roles}
    left_true: dict[tuple[str, tuple[tuple[str, str], ...]], set[ir.Expr]] = {}
    # Phases that run one primitive on the same roles after the same previous primitive share
    # their unchecked requirements: one warning names them all (n such phases of a primitive with
    # m requirements would otherwise cost n x m).
    previous: set[ir.Expr] = set()
    groups: dict[tuple[int, int], tuple[tuple[ir.Clause, ...], set[ir.Expr], list[ir.Phase]]] = {}
    for phase in s.phases:
        key = (id(phase.unchecked_requires), id(previous))
        groups.setdefault(key, (phase.unchecked_requires, previous, []))[2].append(phase)
        after = (phase.primitive, phase.role_map)
        if after not in left_true:
            role_map = dict(phase.role_map)
            left_true[after] = {c for clause in primitives[phase.primitive].success
                                for c in conjuncts(substitute_roles(clause.expr, role_map, roles))}
        previous = left_true[after]
    for unchecked, left, phases in groups.values():
        first = phases[0]
        when = f"phase `{first.name}` starts" if len(phases) == 1 else \
            f"phases {listing(p.name for p in phases)} start"
        for clause in unchecked:
            if all(c in left for c in conjuncts(clause.expr)):
                continue  # the previous phase's success left it true
            out.append(warning(
                "W0105", f"`{clause.text}` is not in the strategy's `requires`; it is checked "
                f"at run time when {when}", _phase_header(first, text),
                related=[(f"required by `{first.primitive}`", clause.span)],
                help="state it in the strategy's `requires` if it holds from the start"))
    return out


def _phase_header(phase: ir.Phase, text: str) -> Span:
    """`phase tip: flip(...)`: the phase's first line up to its argument block."""
    sp = phase.span
    first = snippet(text, sp).split("\n")[0].rstrip()
    if first.endswith("{"):
        first = first[:-1].rstrip()
    return Span(sp.path, sp.start, sp.start + len(first), sp.line, sp.col, sp.line,
                sp.col + len(first))
