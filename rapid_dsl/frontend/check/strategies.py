"""Checking a strategy: roles, lets, phases (role maps, arguments, `solve`) -> ir.Strategy."""

from __future__ import annotations

from collections.abc import Callable
from functools import partial
from itertools import islice

from rapid_dsl.frontend import ir
from rapid_dsl.frontend import syntax as ast
from rapid_dsl.frontend.check.common import (
    Ahead,
    Blocks,
    Names,
    check_clauses,
    check_roles,
    constant,
    constant_env,
    format_value,
    hide,
    role_locals,
    value_type,
)
from rapid_dsl.frontend.check.expressions import ExprChecker, depends_on, is_error
from rapid_dsl.frontend.check.fold import fold
from rapid_dsl.frontend.check.primitives import PrimitiveInfo
from rapid_dsl.frontend.check.scope import Env, Globals, Hidden, Local
from rapid_dsl.frontend.check.signatures import resolve_type
from rapid_dsl.frontend.check.text import listing, suggest
from rapid_dsl.frontend.modules import Entry
from rapid_dsl.frontend.tree import walk
from rapid_dsl.frontend.types import ERROR, REAL, EntityType, assignable
from rapid_dsl.language.diagnostics import Diagnostic, Span, error
from rapid_dsl.language.kinds import KIND_PARENTS, is_subkind
from rapid_dsl.language.limits import MAX_RETRY

OBJECTIVE_HELP = "the objective must be dimensionless; divide by a scale, e.g. `norm(d) / 1cm`"
ON_FAIL = ("stop", "continue")   # what a phase's failure does to its strategy (stop: the default)
RETRY_HELP = (f"a phase is tried at most {MAX_RETRY} more times: each attempt is a whole phase's "
              "optimization (docs/language.md, Limits)")


class StrategyChecker:
    def __init__(self, decl: ast.Strategy, ir_name: str, text: str, path: str,
                 globals_: Globals, primitive: Callable[[Entry], PrimitiveInfo | None],
                 diagnostics: list[Diagnostic]) -> None:
        self.decl = decl
        self.ir_name = ir_name
        self.text = text
        self.path = path
        self.globals = globals_
        self.primitive = primitive
        self.diagnostics = diagnostics
        self.exprs = ExprChecker(text, diagnostics)
        self.names = Names(diagnostics)
        self.roles: dict[str, ir.Role] = {}
        self.role_names: list[str] = []
        self.first_of_kind: dict[str, str] = {}     # entity kind -> its first strategy role
        self.stated: set[ir.Expr] | None = None     # conjuncts of the strategy's `requires`
        self.unchecked_of: dict[tuple[str, tuple[tuple[str, str], ...]],
                                tuple[ir.Clause, ...]] = {}

    def err(self, code: str, message: str, span: Span, *, help: str | None = None,
            related: list[tuple[str, Span]] | None = None) -> None:
        self.diagnostics.append(error(code, message, span, help=help, related=related or []))

    def check(self) -> ir.Strategy:
        d = self.decl
        blocks = Blocks(d.blocks, self.diagnostics)
        for kind, name, example in ((ast.Goal, "goal", 'goal "What the strategy achieves"'),
                                    (ast.Roles, "roles",
                                     "roles { box: Object, hand: Manipulator }")):
            if kind not in blocks:
                self.err("E0401", f"strategy `{d.name.name}` has no `{name}` block", d.name.span,
                         help=f"add `{example}`")
        phases_ast = [b for b in d.blocks if isinstance(b, ast.Phase)]
        if not phases_ast:
            self.err("E0401", f"strategy `{d.name.name}` has no `phase`", d.name.span,
                     help="add e.g. `phase take: grasp(target=box, hand=hand)`")
        roles = check_roles(blocks.get(ast.Roles), self.names, self.diagnostics)
        role_scope = role_locals(roles)
        self.roles = {r.name: r for r in roles}
        self.role_names = [r.name for r in role_scope]
        for local in role_scope:
            have = _kind_of(local)
            if have is not None:
                self.first_of_kind.setdefault(have, local.name)
        env = Env(self.globals).with_locals(*role_scope, hidden=self.solve_hidden(phases_ast))
        lets, env = self.lets([b for b in d.blocks if isinstance(b, ast.Let)], env)
        requires_block = blocks.get(ast.Requires)
        requires: tuple[ir.Clause, ...] = ()
        if requires_block is not None:
            hidden = hide(self.names.seen, "E0211", "`requires` may use only roles; `{name}` is "
                          "a {kind}", "requirements are checked when roles are bound",
                          only={"let"})
            renv = Env(self.globals, {r.name: r for r in role_scope}, hidden)
            requires = check_clauses(self.exprs, requires_block.relations,
                                     renv, "a requirement", self.text)
        phases = []
        seen_phases: dict[str, Span] = {}
        for phase in phases_ast:
            if phase.name.name in seen_phases:
                self.err("E0202", f"phase `{phase.name.name}` is declared twice", phase.name.span,
                         related=[("first declared", seen_phases[phase.name.name])],
                         help="phase names are unique within a strategy")
            seen_phases.setdefault(phase.name.name, phase.name.span)
            checked = self.phase(phase, env, requires)
            if checked is not None:
                phases.append(checked)
        success_block = blocks.get(ast.Success)
        success = check_clauses(self.exprs, success_block.clauses, env,
                                "a success clause", self.text) if success_block else ()
        filter_block = blocks.get(ast.Filter)
        filters = check_clauses(self.exprs, filter_block.clauses, env,
                                "a filter clause", self.text) if filter_block else ()
        goal = blocks.get(ast.Goal)
        return ir.Strategy(self.ir_name, goal.text if goal else "",
                           tuple(roles), requires, tuple(lets), tuple(phases), success, filters,
                           self.path, d.span)

    def solve_hidden(self, phases: list[ast.Phase]) -> dict[str, Hidden]:
        hidden = {}
        for phase in phases:
            for arg in phase.args:
                if isinstance(arg.value, ast.Solve):
                    name = arg.value.var.name
                    hidden[name] = Hidden(
                        "E0211", f"`{name}` is the variable of a `solve` and exists only inside it",
                        f"use the phase argument `{arg.name.name}` or solve again")
        return hidden

    def lets(self, items: list[ast.Let], env: Env) -> tuple[list[ir.Let], Env]:
        out = []
        ahead = Ahead([i.name.name for i in items], lambda n: Hidden(
            "E0210", f"`{n}` is used before it is defined",
            "a `let` may use only roles and earlier lets"))
        env = env.child(ahead.hidden)
        for item in items:
            expr = self.exprs.check(item.value, env)
            ahead.passed(item.name.name)
            if isinstance(expr.type, EntityType):
                self.err("E0316", f"a `let` is a value, not an entity ({expr.type})",
                         item.value.span, help="name roles directly")
                expr = ir.Unary("-", expr, ERROR, expr.span)
            if self.names.declare(item.name, "let"):
                out.append(ir.Let(item.name.name, expr, item.span))
                env.define(Local("let", item.name.name, expr.type, item.name.span))
        return out, env

    # phases ---------------------------------------------------------------------------------------
    def phase(self, phase: ast.Phase, env: Env, requires: tuple[ir.Clause, ...]
              ) -> ir.Phase | None:
        info = self.lookup_primitive(phase)
        for arg in phase.args:  # arguments are checked even when the primitive is unknown
            if info is None:
                self.argument_value(arg, env, None)
        if info is None:
            for binding in phase.role_map:
                self.strategy_role(binding, env)
            return None
        prim = info.ir
        role_map = self.role_map(phase, info, env)
        args = self.arguments(phase, info, env)
        key = (prim.name, tuple(role_map))
        unchecked = self.unchecked_of.get(key)
        if unchecked is None:  # phases that run one primitive on the same roles share it
            unchecked = self.unchecked_of[key] = self.unchecked(prim, dict(role_map), requires)
        return ir.Phase(phase.name.name, prim.name, tuple(role_map), tuple(args), unchecked,
                        phase.span, self.on_fail(phase), self.retry(phase, env))

    def on_fail(self, phase: ast.Phase) -> str:
        if phase.on_fail is None:
            return "stop"
        if phase.on_fail.name not in ON_FAIL:
            self.err("E0406", f"`on_fail` takes `stop` or `continue`, not `{phase.on_fail.name}`",
                     phase.on_fail.span,
                     help="write `on_fail continue` to run the next phases after a failure")
            return "stop"
        return phase.on_fail.name

    def retry(self, phase: ast.Phase, env: Env) -> int:
        """`retry N`: a constant non-negative integer, at most MAX_RETRY (0 when absent)."""
        if phase.retry is None:
            return 0
        cenv = constant_env(env, self.names.seen, "`retry`")
        _, value = constant(self.exprs, phase.retry, cenv, REAL, "`retry`")
        if not isinstance(value, float):
            return 0
        if not value.is_integer() or value < 0:
            self.err("E0406", "`retry` must be a non-negative integer", phase.retry.span,
                     help="write how many more times a failed phase is tried, e.g. `retry 2`")
            return 0
        if value > MAX_RETRY:
            shown = f"{value:.0f}" if value < 1e15 else f"{value:.3g}"
            self.diagnostics.append(error(
                "E0413", f"`retry` {shown} is above the maximum of {MAX_RETRY}",
                phase.retry.span, label=f"at most {MAX_RETRY}", help=RETRY_HELP))
            return 0
        return int(value)

    def lookup_primitive(self, phase: ast.Phase) -> PrimitiveInfo | None:
        name = phase.primitive.name
        entry = self.globals.entries.get(name)
        if entry is None:
            if self.globals.incomplete:
                return None
            available = self.globals.primitives
            hint = self.globals.hints(lambda: suggest(name, available)
                                      + f"primitives here: {listing(available) or 'none'}; ", "")
            self.err("E0201", f"unknown primitive `{name}`", phase.primitive.span,
                     help=f"{hint}bring one in with `use stdlib.{name}`")
            return None
        if not isinstance(entry.decl, ast.Primitive):
            kind = {ast.Strategy: "strategy", ast.RelationDecl: "relation",
                    ast.DefDecl: "def"}[type(entry.decl)]
            self.err("E0213", f"`{name}` is a {kind}; a phase runs a primitive",
                     phase.primitive.span)
            return None
        return self.primitive(entry)

    def strategy_role(self, binding: ast.RoleBinding, env: Env) -> Local | None:
        target = binding.target.name
        local = env.scope.get(target)
        if local is not None and local.kind == "role":
            return local
        if local is not None:
            self.err("E0211", f"`{target}` is a {local.kind}; a role map names strategy roles",
                     binding.target.span)
            return None
        roles = self.role_names
        self.err("E0201", f"unknown role `{target}`", binding.target.span,
                 help=self.globals.hints(lambda: suggest(target, roles)
                                         + f"the strategy's roles are {listing(roles)}"))
        return None

    def role_map(self, phase: ast.Phase, info: PrimitiveInfo, env: Env
                 ) -> list[tuple[str, str]]:
        prim, wanted = info.ir, info.roles
        mapped: dict[str, tuple[str, Span]] = {}
        for binding in phase.role_map:
            role = binding.role.name
            target = self.strategy_role(binding, env)
            if role not in wanted:
                self.err("E0503", f"`{prim.name}` has no role `{role}`", binding.role.span,
                         help=self.globals.hints(partial(_unknown_role, role, wanted)))
                continue
            if role in mapped:
                self.err("E0502", f"role `{role}` is mapped twice", binding.span,
                         related=[("first mapped", mapped[role][1])],
                         help="map each role of the primitive exactly once")
                continue
            if target is None:
                mapped[role] = ("", binding.span)
                continue
            need = wanted[role].kind
            have = target.type.kind if isinstance(target.type, EntityType) else None
            if have is not None and need in KIND_PARENTS and not is_subkind(have, need):
                self.err("E0504", f"role `{role}` of `{prim.name}` needs {_a(need)}, but "
                         f"`{target.name}` is {_a(have)}", binding.span,
                         help=f"map a strategy role of kind {need} or a subkind")
            mapped[role] = (target.name, binding.span)
        if len(mapped) < len(wanted):
            # at most 12 named: the work stays that of the phase, not of the primitive's roles
            missing = list(islice((r for r in wanted if r not in mapped), 13))
            more = ", ..." if len(missing) > 12 else ""
            self.err("E0501", f"phase `{phase.name.name}` does not map "
                     + ", ".join(f"`{r}` ({wanted[r].kind})" for r in missing[:12]) + more
                     + f" of `{prim.name}`", _header(phase),
                     help="add " + ", ".join(f"`{r}={self.fitting_role(wanted[r].kind)}`"
                                             for r in missing[:12]) + more)
        return sorted(((r, target) for r, (target, _) in mapped.items() if target),
                      key=lambda pair: info.role_order[pair[0]])

    def fitting_role(self, kind: str) -> str:
        """The first strategy role of `kind` or a subkind, else `...`."""
        for have, name in self.first_of_kind.items():
            if is_subkind(have, kind):
                return name
        return "..."

    def arguments(self, phase: ast.Phase, info: PrimitiveInfo, env: Env) -> list[ir.Argument]:
        prim, params = info.ir, info.params
        given: dict[str, ir.Argument] = {}
        for arg in phase.args:
            name = arg.name.name
            param = params.get(name)
            if param is None:
                self.argument_value(arg, env, None)
                self.err("E0507", f"`{prim.name}` has no param `{name}`", arg.name.span,
                         help=self.globals.hints(partial(_unknown_param, name, params)))
                continue
            if name in given:
                self.argument_value(arg, env, None)
                self.err("E0506", f"param `{name}` is given twice", arg.name.span,
                         related=[("first given", given[name].span)], help="keep one")
                continue
            value = self.argument_value(arg, env, param)
            given[name] = ir.Argument(name, value, arg.span)
            if not isinstance(value, ir.Solve) and \
                    value.type == param.type and param.low is not None and param.high is not None:
                self.range_check(arg, value, param, info)
        given_required = sum(1 for p in given if params[p].default is None)
        if given_required < len(info.required):
            # at most 12 named: the work stays that of the phase, not of the primitive's params
            missing = list(islice((p for p in info.required if p not in given), 13))
            more = ", ..." if len(missing) > 12 else ""
            self.err("E0505", f"phase `{phase.name.name}` gives no value for "
                     + ", ".join(f"`{m}`" for m in missing[:12]) + more + f" of `{prim.name}`",
                     _header(phase), help="add a block `{ " + "; ".join(
                         f"{m} = ..." for m in missing[:12]) + more + " }` after the role map")
        return sorted(given.values(), key=lambda a: info.param_order[a.param])

    def range_check(self, arg: ast.Argument, value: ir.Expr, param: ir.Param,
                    info: PrimitiveInfo) -> None:
        folded = fold(value)
        if not isinstance(folded, float) or is_error(value.type):
            return
        assert param.low is not None and param.high is not None
        if not param.low - 1e-12 <= folded <= param.high + 1e-12:
            shown = format_value(folded, param.type)
            self.err("E0509", f"`{param.name}` = {shown} is outside the range "
                     f"{info.range_text.get(param.name, '')} of `{info.ir.name}`",
                     arg.value.span, help="choose a value inside the range")

    def argument_value(self, arg: ast.Argument, env: Env, param: ir.Param | None
                       ) -> ir.Expr | ir.Solve:
        if isinstance(arg.value, ast.Solve):
            value: ir.Expr | ir.Solve = self.solve(arg.value, env)
            vtype = value.type
        else:
            value = self.exprs.check(arg.value, env)
            vtype = value.type
        if param is None:
            return value
        if not is_error(vtype) and not is_error(param.type) and not assignable(vtype, param.type):
            hint = None
            if not isinstance(arg.value, ast.Solve):
                hint = self.exprs.unit_help(arg.value, arg.value, param.type, param.type,
                                            "give the number a unit")
            self.err("E0508", f"param `{param.name}` expects {param.type}, got {vtype}",
                     arg.value.span if not isinstance(arg.value, ast.Solve)
                     else arg.value.var.span, help=hint)
        return value

    def solve(self, node: ast.Solve, env: Env) -> ir.Solve:
        t = resolve_type(node.type, self.diagnostics)
        if not value_type(t) and t is not ERROR:
            self.err("E0316", f"a solve variable is a quantity or a vector, not {t}",
                     node.type.span, help="e.g. `solve d: Point minimize ...`")
            t = ERROR
        var = node.var.name
        if var in env.scope:
            self.err("E0202", f"`{var}` is already a {env.scope[var].kind}", node.var.span,
                     help="give the solve variable another name")
        senv = env.inner(Local("solve_var", var, t, node.var.span))
        senv.solve_var = var
        objective = self.exprs.check(node.objective, senv)
        if not is_error(objective.type) and objective.type != REAL:
            self.err("E0308", f"the objective must be a Real number, got {objective.type}",
                     node.objective.span, help=OBJECTIVE_HELP)
        constraints = []
        for c in node.constraints:
            expr = self.exprs.check(c, senv)
            if not isinstance(expr, ir.Compare) or expr.op == "!=":
                if not is_error(expr.type):
                    self.err("E0318", "a `subject` constraint must be a comparison "
                             "(`<`, `<=`, `>`, `>=` or `==`)", c.span,
                             help="write one comparison per line, e.g. `norm(d) < 10cm`")
            constraints.append(expr)
        if not any(depends_on(e, "solve_var") for e in (objective, *constraints)) and \
                t is not ERROR:
            self.err("E0318", f"the solve does not depend on `{var}`", node.var.span,
                     help=f"use `{var}` in the objective or the constraints")
        return ir.Solve(var, t, objective, tuple(constraints), t, node.span)

    # requirements the strategy does not state -----------------------------------------------------
    def unchecked(self, prim: ir.Primitive, role_map: dict[str, str],
                  requires: tuple[ir.Clause, ...]) -> tuple[ir.Clause, ...]:
        if self.stated is None:
            self.stated = {c for clause in requires for c in conjuncts(clause.expr)}
        out = []
        for clause in prim.requires:
            if any(isinstance(n, ir.Ref) and n.kind == "role" and n.name not in role_map
                   for n in walk(clause.expr)):
                continue  # an unmapped role was reported already
            renamed = substitute_roles(clause.expr, role_map, self.roles)
            if all(c in self.stated for c in conjuncts(renamed)):
                continue
            out.append(ir.Clause(renamed, _rename_text(clause, role_map), clause.span))
        return tuple(out)


def _unknown_role(role: str, wanted: dict[str, ir.Role]) -> str:
    return suggest(role, wanted) + "its roles are " + listing(
        f"{r}: {wanted[r].kind}" for r in wanted)


def _unknown_param(name: str, params: dict[str, ir.Param]) -> str:
    return suggest(name, params) + f"its params are: {listing(params) or 'none'}"


def _header(phase: ast.Phase) -> Span:
    """`phase tip: flip(...)` without the argument block."""
    end = phase.role_map[-1].span if phase.role_map else phase.primitive.span
    return phase.span.to(end)


def conjuncts(expr: ir.Expr) -> list[ir.Expr]:
    if isinstance(expr, ir.Logic) and expr.op == "and":
        return [*conjuncts(expr.left), *conjuncts(expr.right)]
    return [expr]


def substitute_roles(expr: ir.Expr, role_map: dict[str, str], roles: dict[str, ir.Role]
                     ) -> ir.Expr:
    """The expression with the primitive's roles replaced by the strategy's (types too)."""
    def sub(e: ir.Expr) -> ir.Expr:
        return substitute_roles(e, role_map, roles)

    match expr:
        case ir.Ref(kind="role", name=name, type=old, span=span):
            target = role_map.get(name, name)
            role = roles.get(target)
            kind = EntityType(role.kind) if role and role.kind in KIND_PARENTS else old
            return ir.Ref("role", target, kind, span)
        case ir.BuiltinCall(name=name, args=args, type=t, span=span):
            return ir.BuiltinCall(name, tuple(map(sub, args)), t, span)
        case ir.UserCall(name=name, args=args, type=t, span=span):
            return ir.UserCall(name, tuple(map(sub, args)), t, span)
        case ir.Unary(op=op, operand=a, type=t, span=span):
            return ir.Unary(op, sub(a), t, span)
        case ir.Binary(op=op, left=a, right=b, type=t, span=span):
            return ir.Binary(op, sub(a), sub(b), t, span)
        case ir.Compare(op=op, left=a, right=b, type=t, span=span):
            return ir.Compare(op, sub(a), sub(b), t, span)
        case ir.Logic(op=op, left=a, right=b, type=t, span=span):
            return ir.Logic(op, sub(a), sub(b), t, span)
        case ir.If(cond=c, then=a, orelse=b, type=t, span=span):
            return ir.If(sub(c), sub(a), sub(b), t, span)
        case ir.Vector(items=(a, b, c), type=t, span=span):
            return ir.Vector((sub(a), sub(b), sub(c)), t, span)
        case ir.Component(target=a, index=i, type=t, span=span):
            return ir.Component(sub(a), i, t, span)
        case ir.Start(expr=a, type=t, span=span):
            return ir.Start(sub(a), t, span)
    return expr


def _kind_of(local: Local) -> str | None:
    return local.type.kind if isinstance(local.type, EntityType) else None


def _rename_text(clause: ir.Clause, role_map: dict[str, str]) -> str:
    """The clause's source text with role names replaced, by the spans of the role references."""
    refs = sorted((n for n in walk(clause.expr) if isinstance(n, ir.Ref) and n.kind == "role"),
                  key=lambda n: (n.span.line, n.span.col))
    lines = clause.text.split("\n")
    base_line, base_col = clause.span.line, clause.span.col
    for ref in reversed(refs):
        row = ref.span.line - base_line
        if not 0 <= row < len(lines) or ref.span.end_line != ref.span.line:
            continue
        start = ref.span.col - (base_col if row == 0 else 1)
        end = start + (ref.span.end_col - ref.span.col)
        line = lines[row]
        if line[start:end] == ref.name:
            lines[row] = line[:start] + role_map.get(ref.name, ref.name) + line[end:]
    return "\n".join(lines)


def _a(text: str) -> str:
    return ("an " if text[:1] in "AEIOU" else "a ") + text

