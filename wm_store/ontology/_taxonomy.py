"""The class taxonomy and the relation hierarchy of a loaded ontology, with the checks that
use them: is-a and subclass lookups, sub-/super-properties, and the domains and ranges a
relation allows.

:class:`OntologyTaxonomy` is the first layer of :class:`wm_store.ontology.Ontology`: it
precomputes the closures from the :class:`~wm_store.ontology._terms.Declarations` once (parents
linearized nearest first, ancestors, descendants, and the domain/range checks each relation
inherits), so every check is a dict or set lookup. Unknown names raise the
:mod:`wm_store` class for their kind, naming the closest known names.
"""

from __future__ import annotations

from collections.abc import Iterable, Mapping
from types import MappingProxyType

from wm_store._errors import (
    OntologyError,
    RelationDomainError,
    UnknownClassError,
    UnknownRelationError,
)
from wm_store.ontology._terms import (
    WHERE_TERMS,
    ClassInfo,
    Declarations,
    RelationInfo,
    did_you_mean,
    one_of,
)

__all__ = ["OntologyTaxonomy"]


def _linearize(name: str, parents: Mapping[str, tuple[str, ...]]) -> tuple[str, ...]:
    """``name`` and its ancestors, nearest first (breadth-first); raises on a cycle."""
    order, seen, level = [name], {name}, list(parents.get(name, ()))
    while level:
        following: list[str] = []
        for p in level:
            if p == name:
                raise OntologyError(f"'{name}' is its own ancestor; break the cycle")
            if p not in seen:
                seen.add(p)
                order.append(p)
                following.extend(parents.get(p, ()))
        level = following
    return tuple(order)


class OntologyTaxonomy:
    """Classes and relations of an :class:`~wm_store.ontology.Ontology`, closures precomputed."""

    __slots__ = (
        "_ancestors",
        "_classes",
        "_decl",
        "_descendants",
        "_ordered",
        "_rel_checks",
        "_rel_sub",
        "_rel_super",
    )

    def __init__(self, decl: Declarations) -> None:
        self._decl = decl
        parents = {n: c.parents for n, c in decl.classes.items()}
        for name, info in decl.classes.items():
            for p in info.parents:
                if p not in parents:
                    raise self._unknown_class(p, f"class '{name}': unknown parent", parents)
        self._ordered = {n: _linearize(n, parents) for n in parents}
        self._ancestors = {n: frozenset(o) for n, o in self._ordered.items()}
        self._classes = frozenset(parents)
        below: dict[str, set[str]] = {n: set() for n in parents}
        for n, ancestors in self._ancestors.items():
            for a in ancestors:
                below[a].add(n)
        self._descendants = {n: frozenset(d) for n, d in below.items()}
        rel_parents = {n: r.parents for n, r in decl.relations.items()}
        rel_order = {n: _linearize(n, rel_parents) for n in rel_parents}
        self._rel_super = {n: frozenset(o) for n, o in rel_order.items()}
        rel_below: dict[str, set[str]] = {n: set() for n in rel_parents}
        for n, supers in self._rel_super.items():
            for s in supers:
                rel_below[s].add(n)
        self._rel_sub = {n: frozenset(d) for n, d in rel_below.items()}
        self._rel_checks = {
            n: tuple(
                (decl.relations[a].domains, decl.relations[a].ranges, a)
                for a in order
                if decl.relations[a].domains or decl.relations[a].ranges
            )
            for n, order in rel_order.items()
        }

    # ----------------------------------------------------------------------- classes

    def _unknown_class(
        self, name: str, lead: str = "unknown", pool: Iterable[str] | None = None
    ) -> UnknownClassError:
        hint = did_you_mean(name, self._ancestors if pool is None else pool)
        return UnknownClassError(f"{lead} class {name!r}{hint} {WHERE_TERMS}")

    @property
    def classes(self) -> frozenset[str]:
        return self._classes

    def check_class(self, name: str) -> str:
        """``name`` if it is a class, else UnknownClassError with the closest names."""
        if name not in self._ancestors:
            raise self._unknown_class(name)
        return name

    def _up(self, cls: str) -> frozenset[str]:
        try:
            return self._ancestors[cls]
        except KeyError:
            raise self._unknown_class(cls) from None

    def class_info(self, name: str) -> ClassInfo:
        return self._decl.classes[self.check_class(name)]

    def is_a(self, cls: str, ancestor: str) -> bool:
        """True if ``cls`` is ``ancestor`` or a subclass of it (both must be classes)."""
        try:
            if ancestor in self._ancestors[cls]:
                return True
        except KeyError:
            raise self._unknown_class(cls) from None
        if ancestor not in self._ancestors:
            raise self._unknown_class(ancestor)
        return False

    def subclasses(self, cls: str) -> frozenset[str]:
        """``cls`` and every class below it."""
        try:
            return self._descendants[cls]
        except KeyError:
            raise self._unknown_class(cls) from None

    def superclasses(self, cls: str) -> tuple[str, ...]:
        """``cls`` and every class above it, nearest first."""
        try:
            return self._ordered[cls]
        except KeyError:
            raise self._unknown_class(cls) from None

    # ----------------------------------------------------------------------- relations

    @property
    def relations(self) -> Mapping[str, RelationInfo]:
        return MappingProxyType(self._decl.relations)

    def relation(self, name: str) -> RelationInfo:
        try:
            return self._decl.relations[name]
        except KeyError:
            hint = did_you_mean(name, self._decl.relations)
            raise UnknownRelationError(
                f"unknown relation {name!r}{hint} Relations: {sorted(self._decl.relations)}"
            ) from None

    def subproperties(self, name: str) -> frozenset[str]:
        """``name`` and every relation below it (what a query on ``name`` matches)."""
        self.relation(name)
        return self._rel_sub[name]

    def superproperties(self, name: str) -> frozenset[str]:
        """``name`` and every relation above it."""
        self.relation(name)
        return self._rel_super[name]

    def check_relation(self, subject_type: str, predicate: str, object_type: str) -> RelationInfo:
        """The relation, if a ``subject_type`` may ``predicate`` an ``object_type`` (domains and
        ranges of the relation and its super-properties); else RelationDomainError."""
        info = self.relation(predicate)
        if info.abstract:
            subs = sorted(self._rel_sub[predicate] - {predicate})
            raise RelationDomainError(
                f"'{predicate}' is abstract and cannot be set; use one of {subs}"
            )
        subject_up, object_up = self._up(subject_type), self._up(object_type)
        for domains, ranges, owner in self._rel_checks[predicate]:
            via = "" if owner == predicate else f" (from its super-property '{owner}')"
            for role, cls, up, allowed in (
                ("subject", subject_type, subject_up, domains),
                ("object", object_type, object_up, ranges),
            ):
                if allowed and up.isdisjoint(allowed):
                    raise RelationDomainError(
                        f"cannot relate {subject_type} --{predicate}--> {object_type}: the "
                        f"{role} of '{predicate}' must be {one_of(allowed)}{via}, and {cls} is "
                        f"not ({' < '.join(self._ordered[cls])}); use another relation or class"
                    )
        return info
