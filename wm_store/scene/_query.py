"""Read queries over a :class:`~wm_store.scene.SceneState`, shared by the store and the replica.

``resolve`` finds elements matching a partial description (:class:`~wm_store.protocol.Query`):
type with subclasses, label, property filters and relations they take part in. It starts from
the smallest index it can (label, related element, type) and filters the candidates; it never
scans the graph when an index applies, and it never goes through SPARQL.
"""

from __future__ import annotations

import math
import operator
from collections.abc import Callable, Collection, Iterable
from typing import TYPE_CHECKING, Any

from wm_store.protocol import Element, Pose, Position, PropertyFilter, Query, Relation, Value
from wm_store.scene._numeric_index import RANGE_OPS
from wm_store.scene._state import SceneState

if TYPE_CHECKING:
    from wm_store.ontology import Ontology

__all__ = ["id_sort_key", "match_relations", "resolve"]

WILDCARD = "*"
SELF = "?"


def id_sort_key(element_id: str) -> tuple[str, int, str]:
    """Natural order of ids: ``Part-2`` before ``Part-10`` (ids split as by ``parse_id``)."""
    head, sep, tail = element_id.rpartition("-")
    if sep and head and tail.isdigit():
        return (head, int(tail), "")
    return (element_id, 0, element_id)


def resolve(state: SceneState, ontology: Ontology, query: Query, limit: int = 0) -> list[Element]:
    """Elements matching ``query``, in natural id order, at most ``limit`` (0: all).

    Raises :class:`~wm_store.UnknownClassError` / ``UnknownRelationError`` for names the
    ontology does not know, so a misspelt query fails instead of matching nothing.
    """
    candidates: Collection[str] | None = None
    if query.label:
        candidates = state.ids_with_label(query.label)
    for rel in query.related:
        ontology.relation(rel.predicate)
        found = _ids_related(state, ontology, rel)
        candidates = found if candidates is None else found.intersection(candidates)
    types: Collection[str] = ()
    if query.type:
        cls = ontology.check_class(query.type)
        types = (cls,) if query.exact_type else ontology.subclasses(cls)
    for f in query.filters:
        ontology.data_property(f.property)
    filters = list(query.filters)
    elements = state.elements
    if candidates is None:
        types = types or state.types()
        candidates = _from_range_index(state, types, filters)
        if candidates is None:
            candidates = state.ids_of_types(types)
    elif query.type:
        typeset = set(types)
        candidates = [i for i in candidates if elements[i].type in typeset]
    if not filters:
        ordered = sorted(candidates, key=id_sort_key)
        return [elements[i] for i in (ordered[:limit] if limit else ordered)]
    if len(filters) == 1:
        check = _compile_filter(filters[0])
        matches = [e for e in map(elements.__getitem__, candidates) if check(e)]
    else:
        checks = [_compile_filter(f) for f in sorted(filters, key=lambda f: _COST[f.op])]
        matches = []
        for element_id in candidates:
            element = elements[element_id]
            for check in checks:
                if not check(element):
                    break
            else:
                matches.append(element)
    matches.sort(key=lambda e: id_sort_key(e.id))
    return matches[:limit] if limit else matches


def _from_range_index(
    state: SceneState, types: Collection[str], filters: list[PropertyFilter]
) -> list[str] | None:
    """Members of ``types`` selected through :attr:`SceneState.numeric` by the most selective
    numeric range filter, which is then removed from ``filters``; ``None`` if there is none."""
    best: list[str] | None = None
    used = -1
    for n, f in enumerate(filters):
        want = f.value
        if f.op in RANGE_OPS and isinstance(want, int | float) and not isinstance(want, bool):
            found = state.numeric.select(types, f.property, f.op, float(want))
            if best is None or len(found) < len(best):
                best, used = found, n
    if best is not None:
        del filters[used]
    return best


def _ids_related(state: SceneState, ontology: Ontology, rel: Relation) -> set[str]:
    preds = ontology.subproperties(rel.predicate)
    if rel.subject == SELF and rel.object == SELF:
        return {r.subject for r in state.match_relations("", preds) if r.subject == r.object}
    if rel.subject == SELF:
        obj = "" if rel.object == WILDCARD else rel.object
        return {r.subject for r in state.match_relations("", preds, obj)}
    if rel.object == SELF:
        subject = "" if rel.subject == WILDCARD else rel.subject
        return {r.object for r in state.match_relations(subject, preds)}
    raise ValueError(f"a related pattern needs '?' as subject or object: {rel}")


def match_relations(
    state: SceneState,
    ontology: Ontology,
    subject: str = "",
    predicate: str = "",
    obj: str = "",
    *,
    include_subproperties: bool = True,
) -> list[Relation]:
    """Relations matching the pattern (empty or ``"*"`` is a wildcard), in a stable order."""
    subject = "" if subject == WILDCARD else subject
    obj = "" if obj == WILDCARD else obj
    preds: Iterable[str] | None = None
    if predicate and predicate != WILDCARD:
        ontology.relation(predicate)
        preds = ontology.subproperties(predicate) if include_subproperties else (predicate,)
    rels = list(state.match_relations(subject, preds, obj))
    rels.sort(key=lambda r: (id_sort_key(r.subject), r.predicate, id_sort_key(r.object)))
    return rels


_COST = {"exists": 0, "eq": 1, "ne": 1, "lt": 2, "le": 2, "gt": 2, "ge": 2, "near": 3}
"""Relative cost of a filter check: cheaper checks run first (the result is the same)."""

_ORDER: dict[str, Callable[[Any, Any], bool]] = {
    "lt": operator.lt,
    "le": operator.le,
    "gt": operator.gt,
    "ge": operator.ge,
}


def _compile_filter(f: PropertyFilter) -> Callable[[Element], bool]:
    name, op, want = f.property, f.op, f.value
    if op == "exists":
        return lambda e: name in e.properties
    if op == "eq":
        return lambda e: name in e.properties and e.properties[name] == want
    if op == "ne":
        return lambda e: e.properties.get(name) != want
    if op == "near":
        tol = f.tolerance
        return lambda e: _distance(e.properties.get(name), want) <= tol
    compare = _ORDER[op]
    if isinstance(want, int | float) and not isinstance(want, bool):
        number = float(want)

        def numeric(e: Element) -> bool:
            have = e.properties.get(name)
            return type(have) in (int, float) and compare(have, number)

        return numeric

    def ordered(e: Element) -> bool:
        have = e.properties.get(name)
        if have is None or isinstance(have, bool) or not isinstance(have, int | float | str):
            return False
        try:
            return compare(have, want)
        except TypeError:
            return False

    return ordered


def _distance(a: Value, b: Value) -> float:
    if isinstance(a, int | float) and isinstance(b, int | float):
        return abs(float(a) - float(b))
    pa, pb = _as_position(a), _as_position(b)
    if pa is None or pb is None:
        return math.inf
    return math.dist((pa.x, pa.y, pa.z), (pb.x, pb.y, pb.z))


def _as_position(v: Value) -> Position | None:
    if isinstance(v, Position):
        return v
    if isinstance(v, Pose):
        return v.position
    return None
