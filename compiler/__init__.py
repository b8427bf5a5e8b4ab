"""The compiler: typed IR -> plan (`lower`) -> readable Python module (`render`)."""

from __future__ import annotations

from rapid_dsl.compiler.codegen import GeneratedModule, LineMap, render
from rapid_dsl.compiler.lower import InternalCompilerError, lower
from rapid_dsl.frontend import ir

__all__ = ["GeneratedModule", "InternalCompilerError", "LineMap", "compile_program", "lower",
           "render"]


def compile_program(program: ir.Program) -> GeneratedModule:
    """lower, then render: a checked program as a generated Python module."""
    return render(lower(program))
