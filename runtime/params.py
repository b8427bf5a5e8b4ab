"""A primitive's param values: given arguments over its defaults, plain SI values, range-checked.

Arguments that do not fit a primitive entry's params (unknown, missing) are bad input of the run
(`ArgumentError`); a value outside its param's range is a phase failure (`PhaseError`), because a
strategy's arguments are computed at run time.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from typing import Any

import numpy as np

from rapid_dsl.runtime.judging import Evaluator, PhaseError
from rapid_dsl.runtime.program import Context, Param, Primitive
from rapid_dsl.runtime.results import PhaseResult, format_value, plain


class ArgumentError(ValueError):
    """Arguments of a primitive entry that do not match its params (bad input)."""


def check_arguments(primitive: Primitive, arguments: Mapping[str, Any]) -> None:
    """Raise ArgumentError for an unknown param or a missing one without a default."""
    known = {p.name: p for p in primitive.params}
    for name in arguments:
        if name not in known:
            listed = ", ".join(known) or "none"
            raise ArgumentError(f"`{primitive.name}` has no param `{name}`; its params: {listed}")
    missing = [p.name for p in primitive.params if not p.has_default and p.name not in arguments]
    if missing:
        raise ArgumentError(f"`{primitive.name}` needs --arg for: {', '.join(missing)}")


def given_values(primitive: Primitive, context: Context, arguments: Mapping[str, Any],
                 evaluator: Evaluator) -> dict[str, Any]:
    """The param defaults (evaluated in the context's state) with the arguments over them."""
    values: dict[str, Any] = {}
    if primitive.defaults is not None:
        values.update(evaluator.call(primitive.defaults, context, "param defaults"))
    values.update(arguments)
    return values


def resolve_params(primitive: Primitive, values: Mapping[str, Any],
                   record: PhaseResult) -> dict[str, Any]:
    """Every param's plain SI value, recorded with its unit; PhaseError if missing or out of
    range."""
    params = {}
    for param in primitive.params:
        if param.name not in values:
            raise PhaseError(f"param `{param.name}` of `{primitive.name}` has no value")
        value = plain_param(param, values[param.name])
        params[param.name] = value
        record.arguments[param.name] = plain(value) if param.shape != "bool" else bool(value)
        record.units[param.name] = param.unit
        problem = out_of_range(param, value)
        if problem:
            raise PhaseError(problem)
    return params


def plain_param(param: Param, value: Any) -> Any:
    array = np.asarray(value, dtype=float)
    if param.shape == "vector":
        return array.reshape(-1, 3)[0].copy()
    if param.shape == "bool":
        return bool(np.all(np.asarray(value)))
    return float(array.reshape(-1)[0])


def out_of_range(param: Param, value: Any) -> str | None:
    size = float(np.linalg.norm(value)) if param.shape == "vector" else value
    if param.shape == "bool" or (param.low is None and param.high is None):
        return None
    low = -math.inf if param.low is None else param.low
    high = math.inf if param.high is None else param.high
    if not math.isfinite(size) or not low <= size <= high:
        what = f"|{param.name}|" if param.shape == "vector" else param.name
        bounds = f"[{format_value(param.low, param.unit)}, {format_value(param.high, param.unit)}]"
        return (f"argument {what} = {format_value(size, param.unit)} is outside its range "
                f"{bounds}")
    return None
