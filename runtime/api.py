"""The runtime as a compiled program sees it: its header imports and the names each one offers.

This table is the contract between the compiler and the loader. `rapid_dsl.compiler.lower` emits
exactly the import lines of `IMPORTS`; `rapid_dsl.runtime.allow_list` accepts no other import and no
attribute of an imported name outside its `names`; `rapid_dsl.runtime.loader` answers the imports
with facades holding only those names (so `RT.np`, `RT.re` or `B.os` do not exist at run time
either). Values the generated code builds or receives are reached only through `VALUE_ATTRIBUTES`.
"""

from __future__ import annotations

import importlib
from dataclasses import dataclass
from types import SimpleNamespace

from rapid_dsl.language.registry import BUILTINS


@dataclass(frozen=True, slots=True)
class HeaderImport:
    """`from MODULE import NAME as ALIAS`, offering `ALIAS.<n>` for n in `names`."""

    module: str
    name: str
    alias: str
    names: tuple[str, ...]

    @property
    def line(self) -> str:
        return f"from {self.module} import {self.name} as {self.alias}"

    def facade(self) -> SimpleNamespace:
        """A fresh namespace with only `names`, taken from the real runtime object.

        Imported on demand, so casadi stays out of programs without a `solve`.
        """
        module = importlib.import_module(self.module)
        if not hasattr(module, self.name):      # a submodule not imported yet
            importlib.import_module(f"{self.module}.{self.name}")
        target = getattr(module, self.name)
        return SimpleNamespace(**{n: getattr(target, n) for n in self.names})


# What `rapid_dsl.runtime.program` offers generated code: the declarations it builds, the
# context and the annotations it names, and the operators of the language.
_PROGRAM = (
    "Checks", "ClauseInfo", "Clauses", "Context", "Features", "Keypoint", "Keypoints", "Motion",
    "NO_CHECKS", "Optimize", "Param", "Phase", "Primitive", "Program", "Requirement", "Role",
    "Strategy", "both", "compare", "component", "divide", "either", "negate", "require_abi",
    "scale", "vec", "vec_equal", "where", "where_vec",
)
_SOLVE = ("Problem", "component", "constant", "vec")
_SYMBOLIC = tuple(sorted(name for name, b in BUILTINS.items() if b.symbolic))

RT = HeaderImport("rapid_dsl.runtime", "program", "RT", _PROGRAM)
B = HeaderImport("rapid_dsl.runtime.program", "NUMERIC", "B", tuple(sorted(BUILTINS)))
SV = HeaderImport("rapid_dsl.runtime", "solve", "SV", _SOLVE)
Y = HeaderImport("rapid_dsl.runtime.solve", "SYMBOLIC_NS", "Y", _SYMBOLIC)

IMPORTS: dict[str, HeaderImport] = {i.alias: i for i in (RT, B, SV, Y)}

# Attributes of values (not of imported names) that generated code reads: the fields of
# `program.Context`, `Frames.first` for the start state, and a `solve.Problem`'s variable and
# methods.
VALUE_ATTRIBUTES = frozenset({"frames", "roles", "params", "features", "lets", "first", "var",
                              "minimize", "subject", "solve"})
