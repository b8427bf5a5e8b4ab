"""Every diagnostic code: code -> short title. docs/diagnostics.md and the golden tests read this.

E01xx are the parser's (E011x its YAML form), E02xx names, scopes and modules, E03xx types and
dimensions, E04xx block structure, E05xx role maps and arguments, W01xx lint warnings. A code
keeps its meaning forever.
"""

from __future__ import annotations

CODES: dict[str, str] = {
    # syntax (rapid_dsl/frontend/parser.py)
    "E0101": "syntax error",
    "E0102": "unexpected character",
    "E0103": "unexpected end of file",
    "E0104": "unterminated string",
    "E0105": "unknown unit",
    "E0106": "unknown escape in a string",
    "E0107": "nesting too deep",
    "E0108": "`use` names no declaration",
    "E0109": "keypoint option given twice",
    # the YAML form (rapid_dsl/frontend/yaml/; kept equal to its CODES by a test)
    "E0110": "the file is not well-formed YAML",
    "E0111": "a key or value does not fit the YAML form of a program",
    "E0112": "a list item is not one declaration (use, relation, def, primitive, strategy)",
    "E0113": "a key appears twice in one YAML mapping",
    "E0114": "a name in the YAML form is not a valid name",
    "E0115": "a text holds a line break or a lone surrogate, which `.rapid` text cannot hold",
    "E0116": "the YAML nests too deeply, is too large, or has aliases that refer to themselves",
    # names, scopes and modules
    "E0201": "unknown name",
    "E0202": "duplicate name",
    "E0203": "`use` brings a name twice",
    "E0204": "`use` clashes with a local declaration",
    "E0205": "unknown standard-library name",
    "E0206": "cannot read a used file",
    "E0207": "`use` cycle",
    "E0208": "unknown module",
    "E0209": "`start(...)` outside a primitive",
    "E0210": "name used before it is defined",
    "E0211": "name not available in this block",
    "E0212": "not callable, or a function used as a value",
    "E0213": "wrong kind of declaration",
    "E0214": "recursive definition",
    "E0215": "reserved or builtin name",
    "E0216": "`use` path outside the allowed folders",
    "E0217": "`use` of a file that is not a program",
    # types and dimensions
    "E0301": "mismatched dimensions",
    "E0302": "cannot compare values of different types",
    "E0303": "argument of the wrong type",
    "E0304": "exponent is not an integer literal",
    "E0305": "unknown type",
    "E0306": "unknown component",
    "E0307": "expected Bool",
    "E0308": "cost is not dimensionless",
    "E0309": "operator not defined for these types",
    "E0310": "vector literal needs 3 items",
    "E0311": "vector items of different dimensions",
    "E0312": "component of a non-vector",
    "E0313": "type mismatch",
    "E0314": "not a constant",
    "E0315": "value outside its range",
    "E0316": "type not allowed here",
    "E0317": "dimensions of a generic builtin do not agree",
    "E0318": "invalid `solve`",
    # block structure
    "E0401": "missing required block",
    "E0402": "block or setting given twice",
    "E0403": "no Manipulator role",
    "E0404": "motion without keypoints",
    "E0405": "unknown setting",
    "E0406": "invalid setting value",
    "E0407": "more elites than samples",
    "E0408": "empty block",
    "E0409": "too deeply nested to check",
    "E0410": "optimize budget above its maximum",
    "E0411": "a motion setting (duration, spread) above its maximum",
    "E0412": "more keypoints than the maximum",
    "E0413": "a phase's retry count above its maximum",
    # role maps and arguments
    "E0501": "primitive role not mapped",
    "E0502": "role mapped twice",
    "E0503": "unknown primitive role",
    "E0504": "role of an incompatible kind",
    "E0505": "missing argument",
    "E0506": "argument given twice",
    "E0507": "unknown argument",
    "E0508": "phase argument of the wrong type",
    "E0509": "constant argument outside the param's range",
    "E0510": "too many positional arguments",
    "E0511": "positional argument after a keyword argument",
    # lint (rapidc lint)
    "W0101": "unused role",
    "W0102": "unused param",
    "W0103": "unused resolved feature",
    "W0104": "param not used by success or cost",
    "W0105": "requirement checked at run time",
    "W0106": "constant cost term",
    "W0107": "success ignores the effect params",
    "W0108": "unused let",
    "W0109": "def or relation named like a builtin",
}


def title(code: str) -> str:
    return CODES.get(code, "")
