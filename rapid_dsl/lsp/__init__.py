"""The language server of `rapidc lsp` (docs/editors.md): diagnostics, hover, go to definition,
completion and formatting for `.rapid` files and the YAML form, over LSP on standard input and
output. Needs the `lsp` extra (pygls, lsprotocol); server.py wires the features to pygls.
"""
