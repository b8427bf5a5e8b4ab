"""Checking a primitive: its blocks, scopes, settings and costs -> ir.Primitive."""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Literal, TypeAlias

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
    keyword_span,
    role_locals,
    value_type,
)
from rapid_dsl.frontend.check.expressions import ExprChecker, is_error
from rapid_dsl.frontend.check.scope import Env, Globals, Hidden, Local
from rapid_dsl.frontend.check.signatures import resolve_type
from rapid_dsl.frontend.check.text import short, snippet
from rapid_dsl.frontend.modules import did_you_mean
from rapid_dsl.frontend.types import ERROR, REAL, EntityType, Quantity, VecType
from rapid_dsl.language.diagnostics import Diagnostic, Span, error
from rapid_dsl.language.kinds import is_subkind
from rapid_dsl.language.limits import (
    MAX_DURATION,
    MAX_ELITES,
    MAX_ITERATIONS,
    MAX_KEYPOINTS,
    MAX_SAMPLES,
    MAX_SEED,
    MAX_SPREAD,
    MAX_SPREAD_ANGLE,
)
from rapid_dsl.language.units import ANGLE, DIMENSIONLESS, LENGTH, TIME

COST_HELP = "cost must be dimensionless; divide by a scale, e.g. `((turned - angle) / 10deg)^2`"

# Defaults of omitted settings (docs/language.md, "Defaults").
MOTION_DEFAULTS = {"spread": 0.02, "spread_angle": 0.17453292519943295, "duration": 2.0}
MOTION_MAXIMA = {"spread": MAX_SPREAD, "spread_angle": MAX_SPREAD_ANGLE, "duration": MAX_DURATION}
MOTION_MAXIMUM_HELP = {
    "duration": "a primitive is one local motion; split a longer task into phases",
    "spread": "the spread is how far the CEM's first samples stray from the keypoints",
    "spread_angle": "the spread is how far the CEM's first samples turn from the keypoints",
}
MOTION_TYPES = {"spread": Quantity(LENGTH), "spread_angle": Quantity(ANGLE),
                "duration": Quantity(TIME)}
OPTIMIZE_DEFAULTS = ir.OptimizeSettings()
OPTIMIZE_SETTINGS = ("samples", "elites", "iterations", "seed")
BUDGET_MAXIMA = {"samples": MAX_SAMPLES, "elites": MAX_ELITES, "iterations": MAX_ITERATIONS}
BUDGET_HELP = (f"budgets are at most {MAX_SAMPLES} samples, {MAX_ELITES} elites and "
               f"{MAX_ITERATIONS} iterations (docs/language.md, Limits)")

_REQUIRED = ((ast.Goal, "goal", 'goal "What the primitive achieves"'),
             (ast.Roles, "roles", "roles { target: Object, hand: Manipulator }"),
             (ast.Success, "success", "success { ... }"),
             (ast.CostFinal, "cost final", "cost final = ..."),
             (ast.Motion, "motion", "motion { keypoint reach = pos(target) }"))


# the field `ir` of PrimitiveInfo hides the module inside its class body
_Role: TypeAlias = ir.Role
_Param: TypeAlias = ir.Param


@dataclass(slots=True)
class PrimitiveInfo:
    """A checked primitive and what strategies need to report on it.

    The tables are made once here, not by every phase that runs the primitive: a phase costs
    what it writes, not the size of its primitive."""

    ir: ir.Primitive
    range_text: dict[str, str] = field(default_factory=dict)   # param -> `[20deg, 120deg]`
    roles: dict[str, _Role] = field(init=False)                 # by name, in declaration order
    role_order: dict[str, int] = field(init=False)
    params: dict[str, _Param] = field(init=False)
    param_order: dict[str, int] = field(init=False)
    required: list[str] = field(init=False)                     # params without a default

    def __post_init__(self) -> None:
        self.roles = {r.name: r for r in self.ir.roles}
        self.role_order = {r.name: i for i, r in enumerate(self.ir.roles)}
        self.params = {p.name: p for p in self.ir.params}
        self.param_order = {p.name: i for i, p in enumerate(self.ir.params)}
        self.required = [p.name for p in self.ir.params if p.default is None]


class PrimitiveChecker:
    def __init__(self, decl: ast.Primitive, ir_name: str, text: str, path: str,
                 globals_: Globals, diagnostics: list[Diagnostic]) -> None:
        self.decl = decl
        self.ir_name = ir_name
        self.text = text
        self.path = path
        self.diagnostics = diagnostics
        self.exprs = ExprChecker(text, diagnostics)
        self.names = Names(diagnostics)
        self.base = Env(globals_, allow_start=True)
        self.range_text: dict[str, str] = {}

    def err(self, code: str, message: str, span: Span, *, label: str | None = None,
            help: str | None = None, related: list[tuple[str, Span]] | None = None) -> None:
        self.diagnostics.append(error(code, message, span, label=label, help=help,
                                      related=related or []))

    def check(self) -> PrimitiveInfo:
        d = self.decl
        blocks = Blocks(d.blocks, self.diagnostics)
        for kind, name, example in _REQUIRED:
            if kind not in blocks:
                self.err("E0401", f"primitive `{d.name.name}` has no `{name}` block", d.name.span,
                         help=f"add `{example}`")
        goal = blocks.get(ast.Goal)
        roles_block = blocks.get(ast.Roles)
        roles = check_roles(roles_block, self.names, self.diagnostics)
        if roles_block is not None and not any(
                r.kind != "<error>" and is_subkind(r.kind, "Manipulator") for r in roles):
            self.err("E0403", f"primitive `{d.name.name}` has no Manipulator role",
                     keyword_span(roles_block.span, "roles"),
                     help="add the hand that acts, e.g. `hand: Manipulator`")
        role_scope = role_locals(roles)
        params = self.params(blocks.get(ast.Params))
        param_scope = [Local("param", p.name, p.type, p.span) for p in params]

        motion = blocks.get(ast.Motion)
        keypoint_names = {kp.name.name: kp for kp in (motion.items if motion else ())
                          if isinstance(kp, ast.Keypoint)}
        resolve = blocks.get(ast.Resolve)
        feature_names = [a.name.name for a in (resolve.features if resolve else ())]

        keypoint_hidden = {n: Hidden("E0211", f"keypoint `{n}` is visible only to later keypoints",
                                     "keypoints are positions for the motion, not values of the "
                                     "state") for n in keypoint_names}
        env = self.base.with_locals(*role_scope, *param_scope, hidden=keypoint_hidden)
        features, env = self.features(resolve, env, feature_names)

        requires = self.requires(blocks.get(ast.Requires), role_scope, env)
        success_block = blocks.get(ast.Success)
        success: tuple[ir.Clause, ...] = ()
        if success_block is not None:
            clauses = success_block.clauses
            if not clauses:
                self.err("E0408", "the `success` block is empty",
                         keyword_span(success_block.span, "success"),
                         help="state what holds when the primitive has done its job")
            success = check_clauses(self.exprs, clauses, env, "a success clause", self.text)
        cost_final = self.cost(blocks.get(ast.CostFinal), env)
        progress_block = blocks.get(ast.CostProgress)
        cost_progress = self.cost(progress_block, env) if progress_block else None
        weight = self.weight(progress_block, env)
        keypoints, settings = self.motion(motion, env)
        optimize = self.optimize(blocks.get(ast.Optimize), env)
        filter_block = blocks.get(ast.Filter)
        filters = check_clauses(self.exprs, filter_block.clauses, env,
                                "a filter clause", self.text) if filter_block else ()
        primitive = ir.Primitive(
            name=self.ir_name, goal=goal.text if goal else "",
            roles=tuple(roles), requires=requires, params=tuple(params),
            features=tuple(features), success=success,
            cost_final=cost_final if cost_final is not None else ir.Const(0.0, ERROR),
            cost_progress=cost_progress, progress_weight=weight, keypoints=tuple(keypoints),
            spread=settings["spread"], spread_angle=settings["spread_angle"],
            duration=settings["duration"], optimize=optimize, filter=filters, path=self.path,
            span=d.span)
        return PrimitiveInfo(primitive, self.range_text)

    # params ---------------------------------------------------------------------------------------
    def params(self, block: ast.Params | None) -> list[ir.Param]:
        out = []
        for decl in block.params if block else ():
            t = resolve_type(decl.type, self.diagnostics)
            if not value_type(t) and t is not ERROR:
                help_text = ("entities belong in `roles`" if isinstance(t, EntityType) else
                             "params are quantities or vectors that the strategy chooses")
                self.err("E0316", f"a param is a quantity or a vector, not {t}", decl.type.span,
                         help=help_text)
                t = ERROR
            if not self.names.declare(decl.name, "param"):
                continue
            out.append(self.param(decl, t))
        return out

    def param(self, decl: ast.ParamDecl, t: ir.Type) -> ir.Param:
        name = decl.name.name
        env = constant_env(self.base, self.names.seen, f"the range or default of `{name}`")
        low = high = None
        if decl.low is not None and decl.high is not None:
            if isinstance(t, VecType):
                self.err("E0316", f"a range needs a scalar param; `{name}` is {t}",
                         decl.low.span.to(decl.high.span),
                         help="constrain it in the primitive's success or cost instead")
            elif not is_error(t):
                _, low = constant(self.exprs, decl.low, env, t, f"the lower bound of `{name}`")
                _, high = constant(self.exprs, decl.high, env, t, f"the upper bound of `{name}`")
                self.range_text[name] = "[" + snippet(self.text, decl.low.span) + ", " + \
                    snippet(self.text, decl.high.span) + "]"
                if isinstance(low, float) and isinstance(high, float) and low > high:
                    self.err("E0315", f"the range of `{name}` is empty: "
                             f"{format_value(low, t)} > {format_value(high, t)}",
                             decl.low.span.to(decl.high.span), help="write the smaller bound first")
                    low = high = None
        default = None
        if decl.default is not None and not is_error(t):
            expr, value = constant(self.exprs, decl.default, env, t, f"the default of `{name}`")
            if value is not None:
                default = ir.Const(value, t, decl.default.span)
                if isinstance(value, float) and isinstance(low, float) and \
                        isinstance(high, float) and not low <= value <= high:
                    self.err("E0315", f"the default of `{name}` is outside its range "
                             f"{self.range_text[name]}", decl.default.span,
                             help="choose a default inside the range")
        return ir.Param(name, t, low if isinstance(low, float) else None,
                        high if isinstance(high, float) else None, default, decl.span)

    # resolve --------------------------------------------------------------------------------------
    def features(self, block: ast.Resolve | None, env: Env, names: list[str]
                 ) -> tuple[list[ir.Feature], Env]:
        """The resolve entries, and `env` with them in scope."""
        out: list[ir.Feature] = []
        ahead = Ahead(names, lambda n: Hidden(
            "E0210", f"`{n}` is used before it is defined",
            "resolve entries may use only earlier entries; move it up"))
        env = env.child(ahead.hidden)
        for item in block.features if block else ():
            expr = self.exprs.check(item.value, env)
            ahead.passed(item.name.name)
            if isinstance(expr.type, EntityType):
                self.err("E0316", f"a resolve entry is a value, not an entity ({expr.type})",
                         item.value.span, help="name roles directly")
                expr = ir.Unary("-", expr, ERROR, expr.span)
            if self.names.declare(item.name, "resolved feature"):
                out.append(ir.Feature(item.name.name, expr, item.span))
                env.define(Local("feature", item.name.name, expr.type, item.name.span))
        return out, env

    def requires(self, block: ast.Requires | None, roles: list[Local], env: Env
                 ) -> tuple[ir.Clause, ...]:
        if block is None:
            return ()
        hidden = hide(self.names.seen, "E0211", "`requires` may use only roles; `{name}` is a "
                      "{kind}", "requirements are checked on the scene before the primitive runs",
                      only={"param", "resolved feature", "keypoint"})
        hidden.update({n: h for n, h in env.hidden.items() if n not in hidden})
        requires_env = Env(env.globals, {r.name: r for r in roles}, hidden, True, None)
        return check_clauses(self.exprs, block.relations, requires_env, "a requirement",
                             self.text)

    # costs ----------------------------------------------------------------------------------------
    def cost(self, block: ast.CostFinal | ast.CostProgress | None, env: Env) -> ir.Expr | None:
        if block is None:
            return None
        expr = self.exprs.check(block.expr, env)
        if not is_error(expr.type) and expr.type != REAL:
            message = f"cost must be a Real number, got {expr.type}"
            self.err("E0308", message, block.expr.span,
                     label=f"this is {_a(str(expr.type))}", help=COST_HELP)
        return expr

    def weight(self, block: ast.CostProgress | None, env: Env) -> float:
        if block is None or block.weight is None:
            return 1.0
        cenv = constant_env(env, self.names.seen, "the progress weight")
        _, value = constant(self.exprs, block.weight, cenv, REAL, "the progress weight")
        if not isinstance(value, float):
            return 1.0
        if value < 0:
            self.err("E0406", "the progress weight must not be negative", block.weight.span)
        return value

    # motion ---------------------------------------------------------------------------------------
    def motion(self, block: ast.Motion | None, env: Env
               ) -> tuple[list[ir.Keypoint], dict[str, float]]:
        keypoints: list[ir.Keypoint] = []
        settings = dict(MOTION_DEFAULTS)
        if block is None:
            return keypoints, settings
        given: dict[str, ast.MotionSetting] = {}
        items = [i for i in block.items if isinstance(i, ast.Keypoint)]
        if len(items) > MAX_KEYPOINTS:
            first = items[MAX_KEYPOINTS]
            self.err("E0412", f"`motion` declares {len(items)} keypoints, more than the maximum "
                     f"of {MAX_KEYPOINTS}", Span(first.span.path, first.span.start,
                                                 first.name.span.end, first.span.line,
                                                 first.span.col, first.name.span.end_line,
                                                 first.name.span.end_col),
                     label=f"keypoint {MAX_KEYPOINTS + 1}",
                     help="a primitive is one local motion; split a longer one into phases "
                     "(docs/language.md, Limits)")
        ahead = Ahead([i.name.name for i in items], lambda n: Hidden(
            "E0210", f"keypoint `{n}` is used before it is defined",
            "a keypoint may use only earlier keypoints"))
        env = env.child(ahead.hidden)
        for item in block.items:
            if isinstance(item, ast.Keypoint):
                kp = self.keypoint(item, env)
                ahead.passed(item.name.name)
                env.define(Local("keypoint", kp.name, kp.point.type, item.name.span))
                if self.names.declare(item.name, "keypoint"):
                    keypoints.append(kp)
                continue
            if item.key in given:
                self.err("E0402", f"motion sets `{item.key}` twice", item.span,
                         related=[("first set", given[item.key].span)], help="keep one")
                continue
            given[item.key] = item
            value = self.setting_value(item.key, item.value, MOTION_TYPES[item.key], env)
            if value is not None:
                settings[item.key] = value
        if not keypoints and not any(isinstance(i, ast.Keypoint) for i in block.items):
            self.err("E0404", "`motion` declares no keypoint", keyword_span(block.span, "motion"),
                     help="add e.g. `keypoint reach = pos(target) + 2cm * up`")
        return keypoints, settings

    def setting_value(self, key: str, node: ast.Expr, t: ir.Type, env: Env) -> float | None:
        cenv = constant_env(env, self.names.seen, f"`{key}`")
        _, value = constant(self.exprs, node, cenv, t, f"`{key}`")
        if not isinstance(value, float):
            return None
        if value <= 0:
            self.err("E0406", f"`{key}` must be positive", node.span)
            return None
        maximum = MOTION_MAXIMA[key]
        if value > maximum:
            written = short(self.text, node.span) or format_value(value, t)
            self.err("E0411", f"`{key}` {written} is above the maximum of "
                     f"{format_value(maximum, t)}", node.span,
                     label=f"at most {format_value(maximum, t)}",
                     help=MOTION_MAXIMUM_HELP[key] + " (docs/language.md, Limits)")
            return None
        return value

    def keypoint(self, item: ast.Keypoint, env: Env) -> ir.Keypoint:
        point = self.exprs.check(item.point, env)
        if not is_error(point.type) and point.type != VecType(LENGTH):
            help_text = ("scale a Direction by a length, e.g. `3cm * up`"
                         if point.type == VecType(DIMENSIONLESS) else None)
            self.err("E0313", f"keypoint `{item.name.name}` must be a Point, got {point.type}",
                     item.point.span, help=help_text)
        yaw = self.angle(item.yaw, env, "yaw") if item.yaw is not None else None
        pitch = self.angle(item.pitch, env, "pitch") if item.pitch is not None else None
        roll = self.angle(item.roll, env, "roll") if item.roll is not None else None
        gripper: Literal["open", "closed"] | None = \
            "open" if item.gripper == "open" else "closed" if item.gripper else None
        return ir.Keypoint(item.name.name, point, yaw, pitch, roll, gripper, item.span)

    def angle(self, node: ast.Expr, env: Env, what: str) -> ir.Expr:
        expr = self.exprs.check(node, env)
        if not is_error(expr.type) and expr.type != Quantity(ANGLE):
            hint = self.exprs.unit_help(node, node, Quantity(ANGLE), Quantity(ANGLE),
                                        "give it a unit")
            self.err("E0313", f"`{what}` must be an Angle, got {expr.type}", node.span, help=hint)
        return expr

    # optimize -------------------------------------------------------------------------------------
    def optimize(self, block: ast.Optimize | None, env: Env) -> ir.OptimizeSettings:
        if block is None:
            return OPTIMIZE_DEFAULTS
        values: dict[str, int] = {}
        spans: dict[str, ast.Setting] = {}
        for setting in block.settings:
            key = setting.name.name
            if key not in OPTIMIZE_SETTINGS:
                hint = did_you_mean(key, OPTIMIZE_SETTINGS)
                self.err("E0405", f"unknown optimize setting `{key}`", setting.name.span,
                         help=(hint + " " if hint else "") + "settings are " +
                         ", ".join(f"`{s}`" for s in OPTIMIZE_SETTINGS))
                continue
            if key in spans:
                self.err("E0402", f"optimize sets `{key}` twice", setting.span,
                         related=[("first set", spans[key].span)], help="keep one")
                continue
            spans[key] = setting
            cenv = constant_env(env, self.names.seen, f"`{key}`")
            _, value = constant(self.exprs, setting.value, cenv, REAL, f"`{key}`")
            if not isinstance(value, float):
                continue
            least = 0 if key == "seed" else 1
            if not value.is_integer() or value < least or key == "seed" and value > MAX_SEED:
                what = "a non-negative integer" if key == "seed" else "a positive integer"
                self.err("E0406", f"`{key}` must be {what}", setting.value.span)
                continue
            maximum = BUDGET_MAXIMA.get(key)
            if maximum is not None and value > maximum:
                shown = f"{value:.0f}" if value < 1e15 else f"{value:.3g}"
                self.err("E0410", f"`{key}` {shown} is above the maximum of {maximum}",
                         setting.value.span, label=f"at most {maximum}", help=BUDGET_HELP)
                continue
            values[key] = int(value)
        samples = values.get("samples", OPTIMIZE_DEFAULTS.samples)
        settings = ir.OptimizeSettings(
            samples=samples,
            elites=values.get("elites", min(OPTIMIZE_DEFAULTS.elites, samples)),
            iterations=values.get("iterations", OPTIMIZE_DEFAULTS.iterations),
            seed=values.get("seed"), span=block.span)
        if settings.elites > settings.samples:
            where = spans.get("elites") or spans.get("samples")
            assert where is not None
            self.err("E0407", f"{settings.elites} elites out of {settings.samples} samples",
                     where.span, help="elites are the best samples kept each iteration: "
                     "at most `samples`")
        return settings


def _a(text: str) -> str:
    return ("an " if text[:1] in "AEIOU" else "a ") + text
