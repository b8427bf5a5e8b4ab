"""The language's vocabulary, shared by the front end and the runtime: units and dimensions,
entity kinds, the builtin registry, limits, diagnostics and their codes, program file names and
the safe readers and writers of files.

Imports nothing else of rapid_dsl, so either side may import it (docs/architecture.md).
"""
