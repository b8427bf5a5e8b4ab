"""The YAML form's shape: its diagnostic codes, the pydantic models of each declaration and
the JSON Schema they give (`rapidc schema`)."""


from __future__ import annotations

from collections.abc import Callable
from typing import Annotated, Any, Literal

from pydantic import (
    BaseModel,
    ConfigDict,
    Discriminator,
    Field,
    Tag,
    TypeAdapter,
    WithJsonSchema,
)

# Diagnostic codes of the YAML form (the E011x range).
E_YAML_SYNTAX = "E0110"
E_YAML_SHAPE = "E0111"
E_YAML_DECLARATION = "E0112"
E_YAML_DUPLICATE_KEY = "E0113"
E_YAML_NAME = "E0114"
E_YAML_TEXT = "E0115"
E_YAML_LIMIT = "E0116"

CODES: dict[str, str] = {
    E_YAML_SYNTAX: "the file is not well-formed YAML",
    E_YAML_SHAPE: "a key or value does not fit the YAML form of a program",
    E_YAML_DECLARATION: "a list item is not one declaration (use, relation, def, primitive, "
                        "strategy)",
    E_YAML_DUPLICATE_KEY: "a key appears twice in one YAML mapping",
    E_YAML_NAME: "a name in the YAML form is not a valid name",
    E_YAML_TEXT: "a text holds a line break or a lone surrogate, which `.rapid` text cannot hold",
    E_YAML_LIMIT: "the YAML nests too deeply, is too large, or has aliases that refer to "
                  "themselves",
}

SCHEMA_ID = "urn:rapid-dsl:program-yaml:0"

KINDS = ("use", "relation", "def", "primitive", "strategy")



class _Model(BaseModel):
    model_config = ConfigDict(extra="forbid", populate_by_name=True)


# Every scalar is loaded as text; the schema also allows numbers so editors accept `weight: 0.1`.
Expr = Annotated[str, WithJsonSchema({
    "type": ["string", "number"],
    "description": "An expression in .rapid syntax, e.g. `distance(hand, target) - 1cm`."})]
TypeText = Annotated[str, Field(description="A type, e.g. `Object`, `Length`, `Vec[Length]`, "
                                            "`Length / Time`.")]
Name = Annotated[str, Field(pattern=r"^[a-z_][A-Za-z0-9_]*$",
                            description="A name: a lower-case letter or `_`, then letters, digits "
                                        "or `_`.")]
ExprList = Annotated[list[Expr], Field(description="Expressions, one per item; all must hold.")]


class ParamSpec(_Model):
    """A primitive parameter: `angle: {type: Angle, range: [20deg, 120deg], default: 90deg}`."""

    type: TypeText
    range: Annotated[list[Expr], Field(min_length=2, max_length=2,
                                       description="[low, high], both included")] | None = None
    default: Expr | None = None


class Cost(_Model):
    """`cost final = ...` and `cost progress weight W = ...`."""

    final: Expr | None = None
    progress: Expr | None = None
    weight: Expr | None = Field(None, description="Weight of `progress` (default 1).")


class KeypointSpec(_Model):
    name: Name
    at: Expr = Field(description="The hand position (a Point) at the primitive's start.")
    yaw: Expr | None = None
    pitch: Expr | None = None
    roll: Expr | None = None
    gripper: Literal["open", "closed"] | None = None


class MotionSpec(_Model):
    keypoints: list[KeypointSpec] | None = None
    spread: Expr | None = None
    spread_angle: Expr | None = None
    duration: Expr | None = None


class SolveSpec(_Model):
    """`solve d: Point minimize OBJ subject { ... }` as a mapping."""

    solve: Name
    type: TypeText
    minimize: Expr
    subject: ExprList | None = None


def _text_or(tag: str) -> Callable[[Any], str]:
    """A union's discriminator: a mapping is the model `tag`, anything else text."""
    return lambda value: tag if isinstance(value, dict) else "text"


# Tagged unions so that an error names one branch; tags are never YAML keys (see `_at`).
Argument = Annotated[Annotated[Expr, Tag("text")] | Annotated[SolveSpec, Tag("solve-spec")],
                     Discriminator(_text_or("solve-spec"))]
ParamValue = Annotated[Annotated[TypeText, Tag("text")] | Annotated[ParamSpec, Tag("param-spec")],
                       Discriminator(_text_or("param-spec"))]
_TAGS: dict[str, Any] = {"text": str, "solve-spec": SolveSpec, "param-spec": ParamSpec}


class PhaseSpec(_Model):
    name: Name
    primitive: Name
    roles: dict[Name, Name] | None = Field(None, description="Primitive role -> strategy role.")
    args: dict[Name, Argument] | None = Field(None, description="Primitive param -> value.")
    on_fail: Name | None = Field(None, description="`continue`: the strategy goes on after this "
                                                   "phase fails (default `stop`).")
    retry: Expr | None = Field(None, description="How many more times the phase is tried when it "
                                                 "fails (default 0, at most 5).")


class UseDecl(_Model):
    use: str = Field(description='`stdlib.push`, `stdlib.{push, flip}` or a file such as '
                                 '`lib/shelf.rapid`.')


class RelationDecl(_Model):
    relation: Name
    params: dict[Name, TypeText] | None = None
    body: Expr


class DefDecl(_Model):
    def_: Name = Field(alias="def")
    params: dict[Name, TypeText] | None = None
    returns: TypeText
    body: Expr


class PrimitiveDecl(_Model):
    primitive: Name
    goal: str
    roles: dict[Name, TypeText] | None = None
    requires: ExprList | None = None
    params: dict[Name, ParamValue] | None = None
    resolve: dict[Name, Expr] | None = Field(None, description="Features, evaluated in order.")
    success: ExprList | None = None
    cost: Cost | None = None
    motion: MotionSpec | None = None
    optimize: dict[Name, Expr] | None = None
    filter: ExprList | None = None


class StrategyDecl(_Model):
    strategy: Name
    goal: str
    roles: dict[Name, TypeText] | None = None
    requires: ExprList | None = None
    let: dict[Name, Expr] | None = None
    phases: list[PhaseSpec] | None = None
    success: ExprList | None = None
    filter: ExprList | None = None


_MODELS: dict[str, type[_Model]] = {"use": UseDecl, "relation": RelationDecl, "def": DefDecl,
                                    "primitive": PrimitiveDecl, "strategy": StrategyDecl}


def _declaration_kind(value: Any) -> str | None:
    found = [k for k in KINDS if isinstance(value, dict) and k in value]
    return found[0] if len(found) == 1 else None


Declaration = Annotated[
    Annotated[UseDecl, Tag("use")] | Annotated[RelationDecl, Tag("relation")]
    | Annotated[DefDecl, Tag("def")] | Annotated[PrimitiveDecl, Tag("primitive")]
    | Annotated[StrategyDecl, Tag("strategy")],
    Discriminator(_declaration_kind)]


def json_schema() -> dict[str, Any]:
    """JSON Schema (draft 2020-12) of a YAML program."""
    schema = TypeAdapter(list[Declaration]).json_schema()
    return {"$schema": "https://json-schema.org/draft/2020-12/schema", "$id": SCHEMA_ID,
            "title": "RAPID program (YAML form)",
            "description": "A list of declarations; expressions are strings in .rapid syntax.",
            **schema}
