"""rapid_dsl as a library: check and compile programs for the runtime, returning data.

The command line, the MCP server and the language server are built on these functions.
"""
