"""Entity kinds and their subtyping, shared by the checker and the binder (no heavy imports)."""

from __future__ import annotations

# kind -> its supertypes
KIND_PARENTS: dict[str, tuple[str, ...]] = {
    "Body": (),
    "Object": ("Body",),
    "Fixture": ("Body",),
    "Surface": ("Fixture", "Body"),
    "Manipulator": ("Body",),
}


def is_subkind(kind: str, of: str) -> bool:
    """`Surface` is a `Fixture` is a `Body`.

    >>> is_subkind("Surface", "Body"), is_subkind("Object", "Fixture")
    (True, False)
    """
    return kind == of or of in KIND_PARENTS.get(kind, ())


# A Fixture role needs a side face (a wall to push against, a platform edge to flip against). A
# plane, the floor, has none: its one face is the top everything rests on, so it is a Surface
# only. Box-shaped surfaces (tables, platforms) keep their side faces and may fill Fixture roles.
FACELESS_SHAPES = frozenset({"plane"})


def fills(kind: str, shape: str, role: str) -> bool:
    """Whether an entity of `kind` and `shape` may fill a role of kind `role`.

    >>> fills("Surface", "box", "Fixture"), fills("Surface", "plane", "Fixture")
    (True, False)
    >>> fills("Surface", "plane", "Surface"), fills("Surface", "plane", "Body")
    (True, True)
    """
    if role == "Fixture" and shape in FACELESS_SHAPES:
        return False
    return is_subkind(kind, role)
