"""Cardinality restrictions of a loaded ontology: how many relations of a kind an element may
(maximum, enforced on every write) or should (minimum, reported) have.

:class:`OntologyCardinality` is the layer of :class:`wm_store.ontology.Ontology` over the
taxonomy: it collects the restrictions each class inherits, nearest first, and counts existing
relations through the relation hierarchy (a restriction on ``hasA`` counts its
sub-properties) and the class taxonomy (a qualified restriction counts objects of its class
or below).
"""

from __future__ import annotations

from collections import defaultdict
from collections.abc import Iterable

from wm_store._errors import CardinalityError
from wm_store.ontology._taxonomy import OntologyTaxonomy
from wm_store.ontology._terms import (
    CardinalityRestriction,
    CardinalityShortfall,
    Declarations,
    with_article,
)

__all__ = ["OntologyCardinality"]


class OntologyCardinality(OntologyTaxonomy):
    """The cardinality restrictions of an :class:`~wm_store.ontology.Ontology`."""

    __slots__ = ("_restrictions",)

    def __init__(self, decl: Declarations) -> None:
        super().__init__(decl)
        declared: dict[str, list[CardinalityRestriction]] = defaultdict(list)
        for r in decl.restrictions:
            declared[r.declared_on].append(r)
        self._restrictions = {
            n: tuple(r for a in self._ordered[n] for r in declared.get(a, ()))
            for n in self._ordered
        }

    def restrictions(self, cls: str) -> tuple[CardinalityRestriction, ...]:
        """Cardinality restrictions on ``cls`` and its superclasses, nearest first."""
        self.check_class(cls)
        return self._restrictions[cls]

    def _applicable(
        self, cls: str, relation: str, object_cls: str | None, *, maximum: bool
    ) -> list[CardinalityRestriction]:
        self.check_class(cls)
        if object_cls is not None:
            self.check_class(object_cls)
        related = self.superproperties(relation) if maximum else self.subproperties(relation)
        out = []
        for r in self._restrictions[cls]:
            if r.relation not in related or (r.maximum if maximum else r.minimum) is None:
                continue
            if maximum:  # "max 1 hasA Door" bounds hasA to a MicrowaveDoor too
                ok = r.on_class is None or (
                    object_cls is not None and r.on_class in self._ancestors[object_cls]
                )
            else:  # "min 1 hasA MicrowaveDoor" implies min 1 hasA Door, and min 1 hasA
                ok = object_cls is None or (
                    r.on_class is not None and object_cls in self._ancestors[r.on_class]
                )
            if ok:
                out.append(r)
        return out

    def max_cardinality(self, cls: str, relation: str, object_cls: str | None = None) -> int | None:
        """The tightest maximum of ``relation`` triples for a ``cls`` (from ``cls`` or a
        superclass, on ``relation`` or a super-property); with ``object_cls``, qualified
        restrictions whose class covers it count too."""
        found = [r.maximum for r in self._applicable(cls, relation, object_cls, maximum=True)]
        return min((m for m in found if m is not None), default=None)

    def min_cardinality(self, cls: str, relation: str, object_cls: str | None = None) -> int | None:
        """The largest minimum of ``relation`` triples for a ``cls`` (restrictions on
        ``relation`` or a sub-property; qualified ones count when their class is ``object_cls``
        or below it, and always when ``object_cls`` is None)."""
        found = [r.minimum for r in self._applicable(cls, relation, object_cls, maximum=False)]
        return max((m for m in found if m is not None), default=None)

    def _count(self, r: CardinalityRestriction, existing: Iterable[tuple[str, str]]) -> int:
        subs = self._rel_sub[r.relation]
        return sum(
            1
            for predicate, obj in existing
            if predicate in subs and (r.on_class is None or self.is_a(obj, r.on_class))
        )

    def check_max_cardinality(
        self,
        subject_type: str,
        predicate: str,
        object_type: str,
        existing: Iterable[tuple[str, str]],
    ) -> None:
        """Raise CardinalityError if a ``subject_type`` that already has the ``existing``
        relations ``(predicate, object type)`` may not get one more ``predicate`` to an
        ``object_type``. The store calls this on every relation it adds."""
        current = list(existing)
        for r in self._applicable(subject_type, predicate, object_type, maximum=True):
            count = self._count(r, current)
            if r.maximum is not None and count + 1 > r.maximum:
                raise CardinalityError(
                    f"{with_article(subject_type)} may have {r.describe()}; it already has "
                    f"{count}. Unset one first (or move the object) in the same transaction"
                )

    def check_min_cardinality(
        self, cls: str, existing: Iterable[tuple[str, str]]
    ) -> tuple[CardinalityShortfall, ...]:
        """The minimum cardinalities a ``cls`` with these ``(predicate, object type)`` relations
        falls short of. Reported (e.g. by ``skimesh wm check``), not enforced per write: an
        element is added before its parts."""
        current = list(existing)
        out = []
        for r in self.restrictions(cls):
            if r.minimum:
                count = self._count(r, current)
                if count < r.minimum:
                    message = f"{with_article(cls)} should have {r.describe()}; it has {count}"
                    out.append(CardinalityShortfall(restriction=r, actual=count, message=message))
        return tuple(out)
