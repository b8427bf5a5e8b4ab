"""Typed IR -> ModulePlan: every decision about the generated Python is made here.

The generated module defines plain functions over a `RT.Context` (or, for `requires` clauses, over
frames and entity indices, so the binder can call them) and builds one `RT.Program`. Expressions
become numpy code on batched arrays: builtins through `B.<registry name>` only, the language's
operators through `RT.<operator>`. Inside `solve`, the parts that depend on the decision variable
become CasADi code (`Y.<registry name>`, `SV.*`); everything else is evaluated numerically first and
enters as `SV.constant(...)`.

Names: the generated code's own names start with an upper-case letter (`F`, `C`, `RT`, `B`), which
program names cannot, so program names are used as they are (a Python keyword gets a `_` suffix).
Expressions themselves are lowered by `rapid_dsl.compiler.expressions`.

Program text is untrusted: everything that came from it or from its file names (clause text, goals,
names as data, origins, source file names) enters the module only through `pretty.literal`.
Comments and docstrings are fixed words, digits and generated unit names; names are identifiers
the grammar admitted. Line markers hold an index into the module's `SOURCES` and a line number.
"""

from __future__ import annotations

import sys
from collections.abc import Iterable

from rapid_dsl import __version__
from rapid_dsl.compiler.bodies import Body, names, quantity, returned_dict, returned_tuple
from rapid_dsl.compiler.constants import number
from rapid_dsl.compiler.errors import InternalCompilerError
from rapid_dsl.compiler.expressions import python_identifier, refs
from rapid_dsl.compiler.plan import FunctionPlan, ModulePlan, SectionPlan
from rapid_dsl.compiler.pretty import Call, Raw, Tuple, literal, render_assignment
from rapid_dsl.compiler.sources import SourceFiles
from rapid_dsl.frontend import ir
from rapid_dsl.frontend.parser import MAX_DEPTH
from rapid_dsl.frontend.types import BoolType, Quantity, Type, VecType
from rapid_dsl.language.units import ANGLE, LENGTH, TIME, Dim, si_unit
from rapid_dsl.runtime import api
from rapid_dsl.runtime.program import ABI

__all__ = ["InternalCompilerError", "lower", "python_identifier"]

# Lowering recurses a few frames per level of an expression, which nests at most MAX_DEPTH levels
# (the parser refuses deeper ones), and `solve` inlines defs into each other.
_RECURSION_LIMIT = 1000 + 10 * MAX_DEPTH
# The angle options of a keypoint, as named in ir.Keypoint and runtime Keypoint.
KEYPOINT_ANGLES = ("yaw", "pitch", "roll")


def lower(program: ir.Program) -> ModulePlan:
    """Turn a checked program into the data the module template renders.

    `program` is well-typed, so no user-facing error can occur here.

    Raises:
        InternalCompilerError: an invariant guaranteed by the checker was violated.
    """
    limit = sys.getrecursionlimit()
    sys.setrecursionlimit(max(limit, _RECURSION_LIMIT))
    try:
        return _ModuleLowerer(program).plan()
    finally:
        sys.setrecursionlimit(limit)


# ------------------------------------------------------------------------------------- module

class _ModuleLowerer:
    def __init__(self, program: ir.Program) -> None:
        self.program = program
        self.files = SourceFiles(program.path)
        self.global_names: set[str] = {"F", "F0", "C", *api.IMPORTS, "PROGRAM", "SOURCES"}
        self.function_names: dict[str, str] = {}
        self.uses_solve = False
        self.definitions = {f.name: f for f in program.functions}
        for function in program.functions:
            prefix = "rel" if function.is_relation else "def"
            self.function_names[function.name] = self._global(f"{prefix}_{function.name}")
        self.objects: dict[str, str] = {}
        decls: tuple[ir.Primitive | ir.Strategy, ...] = (*program.primitives, *program.strategies)
        for decl in decls:
            self.objects[decl.name] = self._global(python_identifier(decl.name))

    def _global(self, wanted: str) -> str:
        name = wanted
        while name in self.global_names:
            name += "_"
        self.global_names.add(name)
        return name

    def plan(self) -> ModulePlan:
        sections = [self._function_section(f) for f in self.program.functions]
        sections += [self._primitive(p) for p in self.program.primitives]
        sections += [self._strategy(s) for s in self.program.strategies]
        imports = [api.RT, api.B, *((api.SV, api.Y) if self.uses_solve else ())]
        program = Call("RT.Program", kwargs=(
            ("path", literal(self.files.display(self.program.path))),
            ("primitives", Tuple(tuple(Raw(self.objects[p.name])
                                       for p in self.program.primitives))),
            ("strategies", Tuple(tuple(Raw(self.objects[s.name])
                                       for s in self.program.strategies))),
            ("own", Tuple(tuple(Raw(literal(n)) for n in self.program.own))),
        ))
        return ModulePlan(
            header=f"Generated by rapidc {__version__}. Do not edit.",
            doc="A program compiled to a Python CEM program for rapid_dsl.runtime.executor.\n\n"
                "SOURCES names its files; a `# SOURCES[i]:LINE` comment maps the code below it to "
                "line LINE\nof SOURCES[i].\n",
            imports=tuple(sorted(i.line for i in imports)),
            abi=ABI,
            files=self.files.names,
            sources=render_assignment("SOURCES", Tuple(tuple(Raw(literal(s))
                                                             for s in self.files.names))),
            sections=tuple(sections),
            program=render_assignment("PROGRAM", program),
        )

    # -- defs and relations -------------------------------------------------------------------

    def _function_section(self, function: ir.Function) -> SectionPlan:
        body = Body(self, [("local", n) for n, _ in function.params])
        text = body.x.text(function.body)
        body.marker(function.body.span)
        body.line(f"return {text}")
        lines = (["F0 = F.first()"] if body.uses.start else []) + body.lines
        params = ["F", *(body.scope[("local", n)] for n, _ in function.params)]
        kind = "relation" if function.is_relation else "def"
        plan = FunctionPlan(self.function_names[function.name], ", ".join(params), "",
                            f"{kind}: {_type_text(function.returns)}", tuple(lines))
        return SectionPlan(kind, self.files.marker(function.span), (plan,), ())

    # -- primitives ---------------------------------------------------------------------------

    def _primitive(self, p: ir.Primitive) -> SectionPlan:
        name = self.objects[p.name]
        features = {f.name: f.expr for f in p.features}
        locals_ = ([("role", r.name) for r in p.roles] + [("param", q.name) for q in p.params]
                   + [("feature", f.name) for f in p.features])
        order = [("role", r.name) for r in p.roles] + [("param", q.name) for q in p.params] \
            + [("feature", f.name) for f in p.features]
        functions: list[FunctionPlan] = []

        def context_function(suffix: str, doc: str, returns: str, build, *,  # noqa: ANN001
                             extra_locals: Iterable[tuple[str, str]] = ()) -> str:
            body = Body(self, [*locals_, *extra_locals], features=features)
            tail = build(body)
            lines = body.prologue(order) + body.lines + tail
            fname = self._global(f"{name}_{suffix}")
            functions.append(FunctionPlan(fname, "C: RT.Context", returns, doc, tuple(lines)))
            return fname

        requires = [self._requirement(f"{name}_requires_{i}", c, p.roles, functions)
                    for i, c in enumerate(p.requires)]

        defaults = None
        with_default = [q for q in p.params if q.default is not None]
        if with_default:
            def build_defaults(body: Body) -> list[str]:
                items = [(q.name, body.part(body.x.text(q.default))) for q in with_default
                         if q.default is not None]
                return returned_dict(items)
            defaults = context_function("defaults", "Param defaults, in the primitive's start "
                                        "state.", " -> RT.Features", build_defaults)

        def build_features(body: Body) -> list[str]:
            for f in p.features:
                body.assign("feature", f.name, body.x.text(f.expr), f.span)
            return returned_dict(names((f.name, body.scope[("feature", f.name)])
                                         for f in p.features))
        features_fn = context_function("features", "resolve: features at every recorded time "
                                       "point.", " -> RT.Features", build_features)

        success = self._checks(p.success, lambda build: context_function(
            "success", "success: one value per clause, on the terminal state.", " -> RT.Clauses",
            build))

        def build_cost(expr: ir.Expr) -> object:
            def build(body: Body) -> list[str]:
                text = body.x.text(expr)
                body.marker(expr.span)
                body.line(f"return {text}")
                return []
            return build
        cost_final = context_function("cost_final", "cost final: on the terminal state.", "",
                                      build_cost(p.cost_final))
        cost_progress = None
        if p.cost_progress is not None:
            cost_progress = context_function(
                "cost_progress", "cost progress: at every recorded time point (averaged by the "
                "executor).", "", build_cost(p.cost_progress))

        keypoint_locals = []
        for k in p.keypoints:
            keypoint_locals.append(("keypoint", k.name))
            keypoint_locals += [("keypoint", f"{k.name}_{part}") for part in KEYPOINT_ANGLES
                                if getattr(k, part) is not None]

        def build_keypoints(body: Body) -> list[str]:
            items = []
            for k in p.keypoints:
                ident = body.assign("keypoint", k.name, body.x.text(k.point), k.span)
                args = [literal(k.name), ident]
                for part in KEYPOINT_ANGLES:
                    value = getattr(k, part)
                    if value is not None:
                        body.line(f"{body.scope[('keypoint', f'{k.name}_{part}')]} = "
                                  f"{body.x.text(value)}")
                        args.append(f"{part}={body.scope[('keypoint', f'{k.name}_{part}')]}")
                if k.gripper is not None:
                    args.append(f"grip={1.0 if k.gripper == 'closed' else 0.0}")
                items.append(f"RT.Keypoint({', '.join(args)})")
            return ["return (", *(f"    {i}," for i in items), ")"]
        keypoints = context_function("keypoints", "motion: keypoints in the primitive's start "
                                     "state (the initialization heuristic).", " -> RT.Keypoints",
                                     build_keypoints, extra_locals=keypoint_locals)

        filters = self._checks(p.filter, lambda build: context_function(
            "filter", "filter: which scene variants keep the task's meaning.", " -> RT.Clauses",
            build))

        obj = Call("RT.Primitive", kwargs=(
            ("name", literal(p.name)),
            ("goal", literal(p.goal)),
            ("origin", literal(self.files.origin(p.span))),
            ("roles", Tuple(tuple(Call("RT.Role", (literal(r.name), literal(r.kind)))
                                  for r in p.roles))),
            ("params", Tuple(tuple(self._param(q) for q in p.params))),
            ("requires", Tuple(tuple(requires))),
            ("defaults", Raw(defaults or "None")),
            ("features", Raw(features_fn)),
            ("success", success),
            ("cost_final", Raw(cost_final)),
            ("cost_progress", Raw(cost_progress or "None")),
            ("progress_weight", Raw(number(p.progress_weight))),
            ("motion", Call("RT.Motion", kwargs=(
                ("keypoints", Raw(keypoints)),
                ("names", Tuple(tuple(Raw(literal(k.name)) for k in p.keypoints))),
                ("spread", quantity(p.spread, LENGTH)),
                ("spread_angle", quantity(p.spread_angle, ANGLE)),
                ("duration", quantity(p.duration, TIME)),
            ))),
            ("optimize", Call("RT.Optimize", kwargs=(
                ("samples", Raw(str(p.optimize.samples))),
                ("elites", Raw(str(p.optimize.elites))),
                ("iterations", Raw(str(p.optimize.iterations))),
                ("seed", Raw(repr(p.optimize.seed))),
            ))),
            ("filter", filters),
        ))
        return SectionPlan("primitive", self.files.marker(p.span), tuple(functions),
                           render_assignment(name, obj))

    def _param(self, q: ir.Param) -> Call:
        shape = "vector" if isinstance(q.type, VecType) else \
            "bool" if isinstance(q.type, BoolType) else "scalar"
        dim = q.type.dim if isinstance(q.type, Quantity | VecType) else Dim()
        unit = si_unit(dim)
        return Call("RT.Param", (literal(q.name), literal(_type_text(q.type)), literal(shape)),
                    kwargs=(("low", _optional(q.low, dim)), ("high", _optional(q.high, dim)),
                            ("has_default", Raw(repr(q.default is not None))),
                            ("unit", literal(unit))))

    def _requirement(self, fname: str, clause: ir.Clause, roles: tuple[ir.Role, ...],
                     functions: list[FunctionPlan]) -> Call:
        """A `requires` clause as a relation over the roles it names: `test(F, *indices)`."""
        used = refs([clause.expr])
        other = sorted(k for k, _ in used if k != "role")
        if other:
            raise InternalCompilerError(f"requires clause `{clause.text}` names a {other[0]}")
        names = [r.name for r in roles if ("role", r.name) in used]
        body = Body(self, [("role", n) for n in names])
        text = body.x.text(clause.expr)
        body.marker(clause.span)
        body.line(f"return {text}")
        lines = (["F0 = F.first()"] if body.uses.start else []) + body.lines
        fname = self._global(fname)
        params = ", ".join(["F", *(body.scope[("role", n)] for n in names)])
        functions.append(FunctionPlan(fname, params, "", "requires: one clause, a relation over "
                                      "the roles it names.", tuple(lines)))
        origin = literal(self.files.origin(clause.span))
        return Call("RT.Requirement", (literal(clause.text), origin,
                                       Tuple(tuple(Raw(literal(n)) for n in names)), Raw(fname)))

    def _checks(self, clauses: tuple[ir.Clause, ...], define) -> Call | Raw:  # noqa: ANN001
        if not clauses:
            return Raw("RT.NO_CHECKS")

        def build(body: Body) -> list[str]:
            items = [(self.files.marker(c.span), body.part(body.x.clause(c.expr)))
                     for c in clauses]
            return returned_tuple(items)
        fname = define(build)
        infos = tuple(Call("RT.ClauseInfo", (literal(c.text), literal(self.files.origin(c.span)),
                                             literal(_clause_unit(c.expr))))
                      for c in clauses)
        return Call("RT.Checks", (Tuple(infos), Raw(fname)))

    # -- strategies ---------------------------------------------------------------------------

    def _strategy(self, s: ir.Strategy) -> SectionPlan:
        name = self.objects[s.name]
        locals_ = [("role", r.name) for r in s.roles] + [("let", x.name) for x in s.lets]
        order = list(locals_)
        functions: list[FunctionPlan] = []

        def context_function(suffix: str, doc: str, returns: str, build,  # noqa: ANN001
                             extra_locals: Iterable[tuple[str, str]] = ()) -> str:
            body = Body(self, [*locals_, *extra_locals])
            tail = build(body)
            lines = body.prologue(order) + body.lines + tail
            fname = self._global(f"{name}_{suffix}")
            functions.append(FunctionPlan(fname, "C: RT.Context", returns, doc, tuple(lines)))
            return fname

        requires = [self._requirement(f"{name}_requires_{i}", c, s.roles, functions)
                    for i, c in enumerate(s.requires)]

        def build_lets(body: Body) -> list[str]:
            for let in s.lets:
                body.assign("let", let.name, body.x.text(let.expr), let.span)
            return returned_dict(names((x.name, body.scope[("let", x.name)]) for x in s.lets))
        lets = context_function("lets", "let: evaluated once, in the initial state.",
                                " -> RT.Features", build_lets) if s.lets else "None"

        phases = []
        for phase in s.phases:
            solve_vars = [("solve_var", a.value.var) for a in phase.args
                          if isinstance(a.value, ir.Solve)]
            arg_locals = [("arg", a.param) for a in phase.args] + solve_vars

            def build_args(body: Body, phase: ir.Phase = phase) -> list[str]:
                for arg in phase.args:
                    if isinstance(arg.value, ir.Solve):
                        self._solve(body, arg, arg.value)
                    else:
                        body.assign("arg", arg.param, body.x.text(arg.value), arg.span)
                return returned_dict(names((a.param, body.scope[("arg", a.param)])
                                             for a in phase.args))
            args_fn = context_function(f"{phase.name}_arguments",
                                       "phase: the arguments of its primitive, in the state the "
                                       "previous phase left.", " -> RT.Features",
                                       build_args, extra_locals=arg_locals) \
                if phase.args else "None"
            unchecked = tuple(
                self._requirement(f"{name}_{phase.name}_requires_{i}", c, s.roles, functions)
                for i, c in enumerate(phase.unchecked_requires))
            phases.append(Call("RT.Phase", kwargs=(
                ("name", literal(phase.name)),
                ("primitive", literal(phase.primitive)),
                ("origin", literal(self.files.origin(phase.span))),
                ("role_map", Tuple(tuple(Tuple((Raw(literal(a)), Raw(literal(b))))
                                         for a, b in phase.role_map))),
                ("arguments", Raw(args_fn)),
                ("argument_names", Tuple(tuple(Raw(literal(a.param)) for a in phase.args))),
                ("argument_origins", Tuple(tuple(Raw(literal(self.files.origin(a.span)))
                                                 for a in phase.args))),
                ("unchecked_requires", Tuple(unchecked)),
                # only a phase that continues says so (other programs' modules stay the same)
                *((("on_fail", literal(phase.on_fail)),) if phase.on_fail != "stop" else ()),
                *((("retry", str(phase.retry)),) if phase.retry else ()),
            )))

        success = self._checks(s.success, lambda build: context_function(
            "success", "success: one value per clause, in the final state.", " -> RT.Clauses",
            build))
        filters = self._checks(s.filter, lambda build: context_function(
            "filter", "filter: which scene variants keep the task's meaning.", " -> RT.Clauses",
            build))
        obj = Call("RT.Strategy", kwargs=(
            ("name", literal(s.name)),
            ("goal", literal(s.goal)),
            ("origin", literal(self.files.origin(s.span))),
            ("roles", Tuple(tuple(Call("RT.Role", (literal(r.name), literal(r.kind)))
                                  for r in s.roles))),
            ("requires", Tuple(tuple(requires))),
            ("lets", Raw(lets)),
            ("phases", Tuple(tuple(phases))),
            ("success", success),
            ("filter", filters),
        ))
        return SectionPlan("strategy", self.files.marker(s.span), tuple(functions),
                           render_assignment(name, obj))

    def _solve(self, body: Body, arg: ir.Argument, solve: ir.Solve) -> None:
        """Build and solve a casadi.Opti problem for one argument."""
        self.uses_solve = True
        problem = f"P_{python_identifier(arg.param)}"
        size = 3 if isinstance(solve.var_type, VecType) else 1
        var = body.scope[("solve_var", solve.var)]
        body.marker(solve.span)
        body.lines += [
            f"{problem} = SV.Problem({literal(solve.var)}, {size})",
            f"{var} = {problem}.var",
        ]
        body.line(f"{problem}.minimize({body.x.symbolic(solve.objective)[0]})")
        for constraint in solve.constraints:
            body.marker(constraint.span)
            body.line(f"{problem}.subject({body.x.symbolic(constraint)[0]})")
        body.marker(solve.span)
        body.lines.append(f"{body.scope[('arg', arg.param)]} = {problem}.solve()")
        body.defined.add(("arg", arg.param))


def _clause_unit(e: ir.Expr) -> str:
    if isinstance(e, ir.Compare) and isinstance(e.left.type, Quantity):
        return si_unit(e.left.type.dim)
    return ""


def _type_text(t: Type) -> str:
    return str(t)


def _optional(x: float | None, dim: Dim) -> Raw:
    return Raw("None") if x is None else quantity(float(x), dim)
