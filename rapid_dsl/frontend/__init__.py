"""The front end: `.rapid` text and its YAML form -> syntax tree -> modules -> checked, typed IR,
with diagnostics; lint, the formatter, the language card and the highlighter read the same trees.

Imports only the vocabulary (rapid_dsl.language), never the runtime or the command line.
"""
