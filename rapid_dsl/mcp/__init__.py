"""`rapidc mcp`: the compiler, runner and verifier as Model Context Protocol tools over stdio.

Every tool call is a `rapidc` command run by `rapid_dsl.cli.main`, the function the command line
runs, with its output captured: the same arguments (as JSON), the same checks and exit statuses,
the same JSON it prints with `--format json` (or writes with `--trace`). Quick commands run in a
thread of the server, one at a time; long ones (run, verify, variants, scene from-rgbd) run in a
worker process of their own, which reports its progress lines as MCP progress notifications and
is stopped when the call is cancelled. A call that fails returns an error result; nothing a call
does stops the server.

- tools.py: the tool table (one entry per tool, the place to add one) and each tool's JSON Schema,
  read from the command's own argparse parser.
- arguments.py: JSON arguments -> the command's argv, with inline texts written to a temporary
  folder and every path kept inside the server's folders (docs/agents.md, docs/security.md).
- capture.py: output of a command run in this process, per thread.
- calls.py: one call, from its arguments to its result.
- worker.py: a command run in a worker process, with its progress lines and cancellation.
- results.py: what a command printed -> the call's result (diagnostics, result, output, messages).
- resources.py: the language reference, builtin registry, stdlib sources, diagnostics and card.
- transport.py: stdio, a JSON-RPC message per line, every line answered
  (rapid_dsl/language/jsonrpc.py).
- server.py: the MCP server (the `mcp` SDK's low-level server over transport.py).

Only server.py and transport.py import the `mcp` SDK (the optional extra `rapid-dsl[mcp]`); a
worker process imports none of it.
"""
