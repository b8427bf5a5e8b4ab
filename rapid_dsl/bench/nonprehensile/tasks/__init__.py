"""The benchmark's eight tasks, in the paper's order: one module each, defining `TASK`.

Task `T<i>` is the module `NAMES[i - 1]` of this package, with its strategy `<name>.rapid` and
demonstration scene `<name>.yaml` beside it (rapid_dsl/bench/nonprehensile/spec.py). `MODULES` maps
each key to where its module is found: a dotted module name, or the path of a `.py` file (how a test
adds a task of its own; worker processes load a task the same way from the reference they are
given).
"""

from __future__ import annotations

import importlib
import importlib.util
import sys
from pathlib import Path

from rapid_dsl.bench.nonprehensile.spec import Task

NAMES = ("t1_corridor", "t2_flip_grasp", "t3_obstacles", "t4_reposition", "t5_opening",
         "t6_pivot_corridor", "t7_topple_grasp", "t8_platform_edge")
MODULES: dict[str, str] = {f"T{i}": f"{__name__}.{name}" for i, name in enumerate(NAMES, 1)}


class MissingTask(Exception):
    """An unknown task key, or a task whose module is missing or defines no TASK."""


def load(reference: str) -> Task:
    """The TASK of a module given by dotted name or `.py` path. Raises MissingTask."""
    if reference.endswith(".py"):
        name = f"rapid_dsl_bench_task_{Path(reference).stem}"
        module = sys.modules.get(name)
        if module is None:
            spec = importlib.util.spec_from_file_location(name, reference)
            if spec is None or spec.loader is None or not Path(reference).is_file():
                raise MissingTask(f"the task module {reference} does not exist")
            module = importlib.util.module_from_spec(spec)
            sys.modules[name] = module
            spec.loader.exec_module(module)
    else:
        try:
            module = importlib.import_module(reference)
        except ModuleNotFoundError as exc:
            if exc.name != reference:
                raise   # the module exists and imports something missing: a bug to show
            raise MissingTask(f"the task module {reference} does not exist (yet)") from None
    task = getattr(module, "TASK", None)
    if not isinstance(task, Task):
        raise MissingTask(f"the task module {reference} defines no `TASK = Task(...)`")
    return task


def keys() -> list[str]:
    return list(MODULES)


def task(key: str) -> Task:
    """Task `key` ("T1" .. "T8"). Raises MissingTask naming the key or the missing module."""
    reference = MODULES.get(key.upper())
    if reference is None:
        raise MissingTask(f"no task `{key}`; the tasks are {', '.join(MODULES)}")
    found = load(reference)
    if found.key != key.upper():
        raise MissingTask(f"the task module {reference} defines task {found.key}, not {key}")
    return found


def tasks() -> list[Task]:
    """Every task, in order. Raises MissingTask for the first one whose module is missing."""
    return [task(key) for key in MODULES]


def available() -> list[Task]:
    """The tasks in place: module, strategy and demonstration scene (for tests that cover
    whichever have landed)."""
    found = []
    for key in MODULES:
        try:
            loaded = task(key)
        except MissingTask:
            continue
        if loaded.strategy_path.is_file() and loaded.demo_path.is_file():
            found.append(loaded)
    return found
