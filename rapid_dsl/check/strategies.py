"""Checking a strategy: roles, lets, phases (role maps, arguments, `solve`) -> ir.Strategy."""

from __future__ import annotations

from collections.abc import Callable

from rapid_dsl import ir
from rapid_dsl import syntax as ast
from rapid_dsl.check.common import (
    Blocks,
    Names,
    check_clauses,
    check_roles,
    format_value,
    hide,
    role_locals,
    value_type,
)
from rapid_dsl.check.expressions import ExprChecker, depends_on, is_error, walk
from rapid_dsl.check.fold import fold
from rapid_dsl.check.primitives import PrimitiveInfo
from rapid_dsl.check.scope import Env, Globals, Hidden, Local
from rapid_dsl.check.types import resolve_type
from rapid_dsl.diagnostics import Diagnostic, Span, error
from rapid_dsl.modules import Entry, did_you_mean
from rapid_dsl.runtime.kinds import KIND_PARENTS, is_subkind
from rapid_dsl.typesys import ERROR, REAL, EntityType, assignable

OBJECTIVE_HELP = "the objective must be dimensionless; divide by a scale, e.g. `norm(d) / 1cm`"


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
            checked = self.phase(phase, env, roles, requires)
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
        names = [i.name.name for i in items]
        for i, item in enumerate(items):
            later = {n: Hidden("E0210", f"`{n}` is used before it is defined",
                               "a `let` may use only roles and earlier lets")
                     for n in names[i:] if n not in env.scope}
            expr = self.exprs.check(item.value, env.with_locals(hidden=later))
            if isinstance(expr.type, EntityType):
                self.err("E0316", f"a `let` is a value, not an entity ({expr.type})",
                         item.value.span, help="name roles directly")
                expr = ir.Unary("-", expr, ERROR, expr.span)
            if self.names.declare(item.name, "let"):
                out.append(ir.Let(item.name.name, expr, item.span))
                env = env.with_locals(Local("let", item.name.name, expr.type, item.name.span))
        return out, env

    # phases ---------------------------------------------------------------------------------------
    def phase(self, phase: ast.Phase, env: Env, roles: list[ir.Role],
              requires: tuple[ir.Clause, ...]) -> ir.Phase | None:
        info = self.lookup_primitive(phase)
        for arg in phase.args:  # arguments are checked even when the primitive is unknown
            if info is None:
                self.argument_value(arg, env, None)
        if info is None:
            for binding in phase.role_map:
                self.strategy_role(binding, env)
            return None
        prim = info.ir
        role_map = self.role_map(phase, prim, env)
        args = self.arguments(phase, info, env)
        unchecked = self.unchecked(prim, dict(role_map), {r.name: r for r in roles}, requires)
        return ir.Phase(phase.name.name, prim.name, tuple(role_map), tuple(args), unchecked,
                        phase.span)

    def lookup_primitive(self, phase: ast.Phase) -> PrimitiveInfo | None:
        name = phase.primitive.name
        entry = self.globals.entries.get(name)
        if entry is None:
            if self.globals.incomplete:
                return None
            available = [n for n, e in self.globals.entries.items()
                         if isinstance(e.decl, ast.Primitive)]
            hint = did_you_mean(name, available)
            listing = ", ".join(f"`{n}`" for n in available) or "none"
            self.err("E0201", f"unknown primitive `{name}`", phase.primitive.span,
                     help=(hint + " " if hint else "") + f"primitives here: {listing}; bring one "
                     f"in with `use stdlib.{name}`")
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
        roles = [n for n, lo in env.scope.items() if lo.kind == "role"]
        hint = did_you_mean(target, roles)
        self.err("E0201", f"unknown role `{target}`", binding.target.span,
                 help=(hint + " " if hint else "") + "the strategy's roles are "
                 + ", ".join(f"`{r}`" for r in roles))
        return None

    def role_map(self, phase: ast.Phase, prim: ir.Primitive, env: Env) -> list[tuple[str, str]]:
        wanted = {r.name: r for r in prim.roles}
        mapped: dict[str, tuple[str, Span]] = {}
        for binding in phase.role_map:
            role = binding.role.name
            target = self.strategy_role(binding, env)
            if role not in wanted:
                hint = did_you_mean(role, wanted)
                self.err("E0503", f"`{prim.name}` has no role `{role}`", binding.role.span,
                         help=(hint + " " if hint else "") + "its roles are "
                         + ", ".join(f"`{r}: {wanted[r].kind}`" for r in wanted))
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
        missing = [r for r in wanted if r not in mapped]
        if missing:
            roles = [n for n, lo in env.scope.items() if lo.kind == "role"]
            suggestions = []
            for r in missing:
                fits = [n for n in roles if _kind_of(env.scope[n]) is not None
                        and is_subkind(_kind_of(env.scope[n]) or "", wanted[r].kind)]
                suggestions.append(f"`{r}={fits[0] if fits else '...'}`")
            self.err("E0501", f"phase `{phase.name.name}` does not map "
                     + ", ".join(f"`{r}` ({wanted[r].kind})" for r in missing)
                     + f" of `{prim.name}`", _header(phase),
                     help="add " + ", ".join(suggestions))
        return [(r.name, mapped[r.name][0]) for r in prim.roles if r.name in mapped
                and mapped[r.name][0]]

    def arguments(self, phase: ast.Phase, info: PrimitiveInfo, env: Env) -> list[ir.Argument]:
        prim = info.ir
        params = {p.name: p for p in prim.params}
        given: dict[str, ir.Argument] = {}
        for arg in phase.args:
            name = arg.name.name
            param = params.get(name)
            if param is None:
                self.argument_value(arg, env, None)
                hint = did_you_mean(name, params)
                listing = ", ".join(f"`{p}`" for p in params) or "none"
                self.err("E0507", f"`{prim.name}` has no param `{name}`", arg.name.span,
                         help=(hint + " " if hint else "") + f"its params are: {listing}")
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
        missing = [p.name for p in prim.params if p.default is None and p.name not in given]
        if missing:
            self.err("E0505", f"phase `{phase.name.name}` gives no value for "
                     + ", ".join(f"`{m}`" for m in missing) + f" of `{prim.name}`",
                     _header(phase), help="add a block `{ " + "; ".join(
                         f"{m} = ..." for m in missing) + " }` after the role map")
        return [given[p.name] for p in prim.params if p.name in given]

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
        senv = env.with_locals(Local("solve_var", var, t, node.var.span))
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
    def unchecked(self, prim: ir.Primitive, role_map: dict[str, str], roles: dict[str, ir.Role],
                  requires: tuple[ir.Clause, ...]) -> tuple[ir.Clause, ...]:
        stated = {c for clause in requires for c in conjuncts(clause.expr)}
        out = []
        for clause in prim.requires:
            if any(isinstance(n, ir.Ref) and n.kind == "role" and n.name not in role_map
                   for n in walk(clause.expr)):
                continue  # an unmapped role was reported already
            renamed = substitute_roles(clause.expr, role_map, roles)
            if all(c in stated for c in conjuncts(renamed)):
                continue
            out.append(ir.Clause(renamed, _rename_text(clause, role_map), clause.span))
        return tuple(out)


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

