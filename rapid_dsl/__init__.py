"""rapid_dsl: a typed language, compiler and MuJoCo runtime for relational robot programs.

Kept light on purpose: generated programs import `rapid_dsl.runtime`, which runs this file first.
"""

__version__ = "0.1.0"
