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
