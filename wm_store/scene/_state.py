"""The in-memory scene graph with its native indexes.

:class:`SceneState` holds elements and relations and applies :data:`~wm_store.protocol.Delta`
values to them. It validates nothing (that is :func:`~wm_store.scene.apply_transaction`'s
job) and is shared by the store (authoritative state) and by the client (local replica), so
both index the same way.

Every mutation returns an :data:`Undo` record; applying the undo records of a change in reverse
order restores the state before it. The store keeps them to serve snapshots at past revisions
and to roll back a transaction that fails half-way.

Indexes: by id, by type, by label, relations by subject and by object, the spatial parent of
each element, and sorted numeric property values per type (:mod:`~wm_store.scene._numeric_index`,
built on first use). All lookups are dict/set operations or bisections; nothing here walks the
graph. Elements are replaced, never mutated in place.
"""

from __future__ import annotations

from collections.abc import Collection, Iterable, Iterator
from typing import TypeAlias

import msgspec

from wm_store.protocol import (
    ClassDef,
    ClassDefined,
    Delta,
    Element,
    ElementPut,
    ElementRemoved,
    OntologyDelta,
    Relation,
    RelationAdded,
    RelationRemoved,
    SnapshotReply,
    TemplateDef,
    TemplateDefined,
    TermsDefined,
)
from wm_store.scene._numeric_index import NumericIndexes

__all__ = ["SceneState", "Undo", "parse_id"]


class _RestoreElement(msgspec.Struct, frozen=True):
    id: str
    previous: Element | None


class _RestoreRelation(msgspec.Struct, frozen=True):
    relation: Relation
    present: bool


class _RestoreOntology(msgspec.Struct, frozen=True):
    count: int
    """The length of the ontology log before the delta."""


Undo: TypeAlias = _RestoreElement | _RestoreRelation | _RestoreOntology


def parse_id(element_id: str) -> tuple[str, int] | None:
    """Split ``"KitBox-12"`` into ``("KitBox", 12)``; ``None`` if it is not of that form."""
    head, sep, tail = element_id.rpartition("-")
    if not sep or not head or not tail.isdigit():
        return None
    return head, int(tail)


class SceneState:
    """Elements, relations and indexes. Not thread-safe: one owner task mutates it."""

    def __init__(self) -> None:
        self.revision = 0
        self.digest = ""
        """The store's chain digest at :attr:`revision` (see ``Change.digest``)."""
        self.elements: dict[str, Element] = {}
        self.ontology_log: list[OntologyDelta] = []
        """What the ontology gained beyond the core, in order (replayed by
        :func:`wm_store.ontology.replay`)."""
        self.counters: dict[str, int] = {}
        self.spatial_predicates: frozenset[str] = frozenset()
        self._by_type: dict[str, set[str]] = {}
        self._by_label: dict[str, set[str]] = {}
        self._out: dict[str, dict[str, set[str]]] = {}
        self._in: dict[str, dict[str, set[str]]] = {}
        self._parent: dict[str, Relation] = {}
        self._relation_count = 0
        self.numeric = NumericIndexes(self.elements, self._by_type)

    # ------------------------------------------------------------------ reads

    def get(self, element_id: str) -> Element | None:
        return self.elements.get(element_id)

    def __contains__(self, element_id: object) -> bool:
        return element_id in self.elements

    @property
    def relation_count(self) -> int:
        return self._relation_count

    def types(self) -> Collection[str]:
        """The asserted types that have at least one element."""
        return self._by_type.keys()

    def ids_of_types(self, types: Iterable[str]) -> set[str]:
        out: set[str] = set()
        for t in types:
            ids = self._by_type.get(t)
            if ids:
                out |= ids
        return out

    def ids_with_label(self, label: str) -> set[str]:
        return set(self._by_label.get(label, ()))

    def objects(self, subject: str, predicate: str) -> set[str]:
        return set(self._out.get(subject, {}).get(predicate, ()))

    def subjects(self, obj: str, predicate: str) -> set[str]:
        return set(self._in.get(obj, {}).get(predicate, ()))

    def has_relation(self, rel: Relation) -> bool:
        return rel.object in self._out.get(rel.subject, {}).get(rel.predicate, ())

    def parent(self, element_id: str) -> Relation | None:
        """The spatial relation whose object is ``element_id`` (its one spatial parent)."""
        return self._parent.get(element_id)

    def spatial_children(self, element_id: str) -> list[Relation]:
        out = self._out.get(element_id, {})
        return [
            Relation(element_id, p, o)
            for p in sorted(out.keys() & self.spatial_predicates)
            for o in sorted(out[p])
        ]

    def relations_of(self, element_id: str) -> list[Relation]:
        """Every relation in which ``element_id`` is subject or object."""
        rels = [
            Relation(element_id, p, o)
            for p, os in self._out.get(element_id, {}).items()
            for o in os
        ]
        rels += [
            Relation(s, p, element_id)
            for p, ss in self._in.get(element_id, {}).items()
            for s in ss
            if s != element_id
        ]
        return rels

    def match_relations(
        self, subject: str = "", predicates: Iterable[str] | None = None, obj: str = ""
    ) -> Iterator[Relation]:
        """Relations matching the pattern; an empty subject/object or ``None`` predicates is a
        wildcard. Uses the subject or object index when one is bound."""
        preds = None if predicates is None else set(predicates)
        if subject:
            for p, objs in self._out.get(subject, {}).items():
                if preds is not None and p not in preds:
                    continue
                for o in objs:
                    if not obj or o == obj:
                        yield Relation(subject, p, o)
        elif obj:
            for p, subs in self._in.get(obj, {}).items():
                if preds is not None and p not in preds:
                    continue
                for s in subs:
                    yield Relation(s, p, obj)
        else:
            for s, by_p in self._out.items():
                for p, objs in by_p.items():
                    if preds is not None and p not in preds:
                        continue
                    for o in objs:
                        yield Relation(s, p, o)

    def all_relations(self) -> list[Relation]:
        return list(self.match_relations())

    # ------------------------------------------------------------------ mutations

    def apply(self, delta: Delta) -> Undo:
        """Apply one delta; return what undoes it."""
        match delta:
            case ElementPut(element=e):
                return self.put_element(e)
            case ElementRemoved(id=element_id):
                return self.remove_element(element_id)
            case RelationAdded(relation=r):
                return self.add_relation(r)
            case RelationRemoved(relation=r):
                return self.remove_relation(r)
            case ClassDefined() | TemplateDefined() | TermsDefined():
                self.ontology_log.append(delta)
                return _RestoreOntology(len(self.ontology_log) - 1)
        raise TypeError(f"not a delta: {delta!r}")  # pragma: no cover - exhaustive match

    def undo(self, record: Undo) -> None:
        match record:
            case _RestoreElement(id=element_id, previous=previous):
                if previous is None:
                    self._drop_element(element_id)
                else:
                    self.put_element(previous)
            case _RestoreRelation(relation=r, present=present):
                if present:
                    self.add_relation(r)
                else:
                    self.remove_relation(r)
            case _RestoreOntology(count=count):
                del self.ontology_log[count:]

    @property
    def classes(self) -> list[ClassDef]:
        """The classes taught at run time (``DefineClass``), in order."""
        return [d.cls for d in self.ontology_log if isinstance(d, ClassDefined)]

    @property
    def templates(self) -> dict[str, TemplateDef]:
        """The templates taught at run time (``DefineTemplate``), the newest of each name."""
        return {
            d.template.name: d.template for d in self.ontology_log if isinstance(d, TemplateDefined)
        }

    def put_element(self, element: Element) -> Undo:
        previous = self.elements.get(element.id)
        if previous is not None:
            if previous.type != element.type:
                self._discard(self._by_type, previous.type, element.id)
            if previous.label != element.label:
                self._discard(self._by_label, previous.label, element.id)
        self.numeric.element_put(previous, element)
        self.elements[element.id] = element
        self._by_type.setdefault(element.type, set()).add(element.id)
        if element.label:
            self._by_label.setdefault(element.label, set()).add(element.id)
        parsed = parse_id(element.id)
        if parsed is not None and parsed[1] > self.counters.get(parsed[0], 0):
            self.counters[parsed[0]] = parsed[1]
        return _RestoreElement(element.id, previous)

    def remove_element(self, element_id: str) -> Undo:
        previous = self.elements.get(element_id)
        self._drop_element(element_id)
        return _RestoreElement(element_id, previous)

    def _drop_element(self, element_id: str) -> None:
        element = self.elements.pop(element_id, None)
        if element is None:
            return
        for rel in self.relations_of(element_id):
            self.remove_relation(rel)
        self.numeric.element_dropped(element)
        self._discard(self._by_type, element.type, element_id)
        if element.label:
            self._discard(self._by_label, element.label, element_id)

    def add_relation(self, rel: Relation) -> Undo:
        objs = self._out.setdefault(rel.subject, {}).setdefault(rel.predicate, set())
        if rel.object in objs:
            return _RestoreRelation(rel, True)
        objs.add(rel.object)
        self._in.setdefault(rel.object, {}).setdefault(rel.predicate, set()).add(rel.subject)
        if rel.predicate in self.spatial_predicates:
            self._parent[rel.object] = rel
        self._relation_count += 1
        return _RestoreRelation(rel, False)

    def remove_relation(self, rel: Relation) -> Undo:
        by_p = self._out.get(rel.subject)
        if by_p is None or rel.object not in by_p.get(rel.predicate, ()):
            return _RestoreRelation(rel, False)
        self._discard(by_p, rel.predicate, rel.object)
        if not by_p:
            del self._out[rel.subject]
        in_p = self._in[rel.object]
        self._discard(in_p, rel.predicate, rel.subject)
        if not in_p:
            del self._in[rel.object]
        if self._parent.get(rel.object) == rel:
            del self._parent[rel.object]
        self._relation_count -= 1
        return _RestoreRelation(rel, True)

    @staticmethod
    def _discard(index: dict[str, set[str]], key: str, value: str) -> None:
        values = index.get(key)
        if values is not None:
            values.discard(value)
            if not values:
                del index[key]

    # ------------------------------------------------------------------ whole-state

    def set_spatial_predicates(self, predicates: Iterable[str]) -> None:
        """Declare which predicates are spatial (and rebuild the parent index)."""
        self.spatial_predicates = frozenset(predicates)
        self._parent = {
            r.object: r for r in self.match_relations(predicates=self.spatial_predicates)
        }

    def to_snapshot(self) -> SnapshotReply:
        return SnapshotReply(
            revision=self.revision,
            elements=list(self.elements.values()),
            relations=self.all_relations(),
            counters=dict(self.counters),
            ontology=list(self.ontology_log),
            digest=self.digest,
        )

    @classmethod
    def from_snapshot(cls, snap: SnapshotReply, spatial: Iterable[str] = ()) -> SceneState:
        state = cls()
        state.spatial_predicates = frozenset(spatial)
        for e in snap.elements:
            state.put_element(e)
        for r in snap.relations:
            state.add_relation(r)
        log: list[OntologyDelta] = list(snap.ontology)
        if not log:  # a snapshot written before the ontology log: classes, then templates
            log = [ClassDefined(c) for c in snap.classes]
            log += [TemplateDefined(t) for t in snap.templates]
        for delta in log:
            state.apply(delta)
        for name, n in snap.counters.items():
            state.counters[name] = max(n, state.counters.get(name, 0))
        state.revision = snap.revision
        state.digest = snap.digest
        return state

    def copy(self) -> SceneState:
        return SceneState.from_snapshot(self.to_snapshot(), self.spatial_predicates)
