"""Subcommands of `rapidc`, one module each (see rapid_dsl/cli.py)."""
