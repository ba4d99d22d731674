"""Transactions: validate a list of ops against the ontology and apply them all, or none.

:func:`apply_transaction` mutates a :class:`~wm_store.scene.SceneState` op by op, recording
every mutation as a delta (what the change stream publishes) and an undo record. If any op is
refused, the undo records are applied in reverse and the error propagates: the state is exactly
as before. Rules enforced here:

- element types, relation names and data property names exist in the ontology;
- property values have the declared kind and lie in the declared range (with tolerance);
- relations respect the ontology's domain and range;
- spatial relations (sub-properties of ``spatialRelation``) keep a tree: one spatial parent
  per element, no cycles;
- maximum cardinalities stated in the ontology;
- compare-and-set: ``expect_rev`` on an element op must equal the element's current ``rev``;
- ids are store-assigned ``<Type>-<n>`` and never reused (an explicit id must be fresh);
- every name names one element: no label equals another element's id, labels are unique
  within their kind, and assigned ids skip names used as labels (:mod:`wm_store.scene._names`).
"""

from __future__ import annotations

import time
from collections.abc import Callable, Mapping, Sequence
from typing import NamedTuple

import msgspec
from rdflib import Graph

from wm_store._errors import (
    ConflictError,
    ElementNotFoundError,
    TreeShapeError,
    ValidationError,
)
from wm_store.ontology import Ontology
from wm_store.protocol import (
    AddElement,
    ClassDefined,
    DefineClass,
    DefineTemplate,
    DefineTerms,
    Delta,
    Element,
    ElementPut,
    ElementRemoved,
    Observation,
    Observe,
    Op,
    Relation,
    RelationAdded,
    RelationRemoved,
    RemoveElement,
    SetRelation,
    TemplateDefined,
    TermsDef,
    TermsDefined,
    UnsetRelation,
    UpdateElement,
    Value,
)
from wm_store.scene._names import NameGuard, check_explicit_form, display_name
from wm_store.scene._resolution import merge_observation, resolve_observations
from wm_store.scene._state import SceneState, Undo

__all__ = ["SELF", "TxnResult", "apply_transaction"]

SELF = "$"
"""In ``AddElement.relations``, stands for the element being added."""


class TxnResult(NamedTuple):
    deltas: list[Delta]
    undo: list[Undo]
    ids: dict[str, str]
    ontology: Ontology


def apply_transaction(
    state: SceneState,
    ontology: Ontology,
    ops: Sequence[Op],
    *,
    revision: int,
    now: float | None = None,
    parsed_terms: Mapping[int, Graph] | None = None,
    check: Callable[[list[Delta]], None] | None = None,
) -> TxnResult:
    """Apply ``ops`` to ``state`` as revision ``revision``; all or nothing.

    ``parsed_terms``: the Turtle of :class:`DefineTerms` ops already parsed (by op index), so
    a caller can parse off its event loop. ``check``: called with the deltas once every op
    applied; what it raises undoes them (the store's authorization). Raises a
    :class:`~wm_store.WmError` subclass naming the op (by index) and the problem; the state is
    then unchanged.
    """
    txn = _Txn(state, ontology, revision, time.time() if now is None else now)
    txn.parsed_terms = parsed_terms or {}
    counters = dict(state.counters)
    txn.names = NameGuard(state, counters, _labels_written(ops))
    try:
        for index, op in enumerate(ops):
            try:
                txn.apply(index, op)
            except ValidationError as exc:
                raise type(exc)(f"op #{index} ({type(op).__name__}): {exc}") from exc
        if check is not None:
            check(txn.deltas)
    except BaseException:
        for record in reversed(txn.undo):
            state.undo(record)
        state.counters = counters
        raise
    return TxnResult(txn.deltas, txn.undo, txn.ids, txn.ontology)


def _labels_written(ops: Sequence[Op]) -> list[str]:
    """The labels ``ops`` give elements (assigned ids must not be among them)."""
    return [op.label for op in ops if isinstance(op, AddElement | UpdateElement) and op.label]


class _Txn:
    def __init__(self, state: SceneState, ontology: Ontology, revision: int, now: float) -> None:
        self.state = state
        self.ontology = ontology
        self.revision = revision
        self.now = now
        self.deltas: list[Delta] = []
        self.undo: list[Undo] = []
        self.ids: dict[str, str] = {}
        self.parsed_terms: Mapping[int, Graph] = {}
        self.names = NameGuard(state, dict(state.counters), ())

    # ------------------------------------------------------------------ plumbing

    def _emit(self, delta: Delta) -> None:
        self.undo.append(self.state.apply(delta))
        self.deltas.append(delta)

    def _id(self, ref_or_id: str) -> str:
        return self.ids.get(ref_or_id, ref_or_id)

    def _need(self, ref_or_id: str) -> Element:
        element = self.state.get(self._id(ref_or_id))
        if element is None:
            raise ElementNotFoundError(f"no element {ref_or_id!r}")
        return element

    def _named(self, element_id: str) -> str:
        return display_name(self.state.get(element_id), element_id)

    def _check_rev(self, element: Element, expect_rev: int | None) -> None:
        if expect_rev is not None and element.rev != expect_rev:
            raise ConflictError(
                f"{display_name(element)} is at rev {element.rev}, not the expected {expect_rev}; "
                "re-read it and retry"
            )

    def _check_property(self, element_type: str, name: str, value: Value) -> None:
        if value is None:
            self.ontology.data_property(name)  # deleting: the name must still exist
        else:
            self.ontology.check_property(element_type, name, value)

    def _stamp(self, element: Element, **changes: object) -> Element:
        return msgspec.structs.replace(element, rev=self.revision, updated_at=self.now, **changes)

    # ------------------------------------------------------------------ ops

    def apply(self, index: int, op: Op) -> None:
        match op:
            case AddElement():
                self._add(index, op)
            case UpdateElement():
                self._update(op)
            case Observe():
                self._observe(op)
            case RemoveElement():
                self._remove(op)
            case SetRelation(subject=s, predicate=p, object=o):
                self._set_relation(Relation(self._id(s), p, self._id(o)))
            case UnsetRelation(subject=s, predicate=p, object=o):
                rel = Relation(self._id(s), p, self._id(o))
                self.ontology.relation(p)
                if self.state.has_relation(rel):
                    self._emit(RelationRemoved(rel))
            case DefineClass(cls=cls):
                self.ontology = self.ontology.extend(classes=[cls])
                self._emit(ClassDefined(cls))
            case DefineTemplate(template=template):
                self.ontology = self.ontology.extend(templates=[template])
                self._emit(TemplateDefined(template))
            case DefineTerms(terms=terms):
                self._teach(index, terms)

    def _teach(self, index: int, terms: TermsDef) -> None:
        source = self.parsed_terms.get(index, terms.turtle)
        taught = self.ontology.teach(source, source=terms.source or f"op #{index}")
        if taught.same_terms(self.ontology):
            return  # already known: nothing changes, nothing is published
        self.ontology = taught
        spatial = frozenset(n for n, r in taught.relations.items() if r.spatial)
        if spatial != self.state.spatial_predicates:
            self.state.set_spatial_predicates(spatial)
        self._emit(TermsDefined(terms))

    def _add(self, index: int, op: AddElement) -> None:
        element_type = self.ontology.check_class(op.type)
        for name, value in op.properties.items():
            self._check_property(element_type, name, value)
        element_id = self._new_id(element_type, op.id, op.label)
        self.names.check_label(self.ontology, element_id, element_type, op.label)
        ref = op.ref or f"#{index}"
        if ref in self.ids:
            raise ValidationError(f"ref {ref!r} is used twice in this transaction")
        self.ids[ref] = element_id
        self.ids.setdefault(f"#{index}", element_id)
        props: dict[str, Value] = {k: v for k, v in op.properties.items() if v is not None}
        element = Element(
            id=element_id,
            type=element_type,
            label=op.label,
            properties=props,
            rev=self.revision,
            updated_at=self.now,
        )
        self._emit(ElementPut(element))
        for rel in op.relations:
            s = element_id if rel.subject in (SELF, ref) else self._id(rel.subject)
            o = element_id if rel.object in (SELF, ref) else self._id(rel.object)
            self._set_relation(Relation(s, rel.predicate, o))

    def _new_id(self, element_type: str, explicit: str, label: str) -> str:
        if not explicit:
            return self.names.new_id(element_type, label)
        check_explicit_form(
            element_type, explicit, self.state.counters.get(element_type, 0), self.state
        )
        return self.names.explicit_id(explicit)

    def _update(self, op: UpdateElement) -> None:
        element = self._need(op.id)
        self._check_rev(element, op.expect_rev)
        props = {} if op.mode == "replace" else dict(element.properties)
        for name in op.remove:
            props.pop(name, None)
        for name, value in op.properties.items():
            self._check_property(element.type, name, value)
            if value is None:
                props.pop(name, None)
            else:
                props[name] = value
        observations = {k: v for k, v in element.observations.items() if k in props}
        label = element.label if op.label is None else op.label
        if label != element.label:
            self.names.check_label(self.ontology, element.id, element.type, label)
        self._emit(
            ElementPut(
                self._stamp(element, properties=props, observations=observations, label=label)
            )
        )

    def _observe(self, op: Observe) -> None:
        element = self._need(op.id)
        self._check_property(element.type, op.property, op.value)
        obs = Observation(
            value=op.value,
            source=op.source,
            stamp=self.now if op.stamp is None else op.stamp,
            confidence=op.confidence,
        )
        merged = merge_observation(element.observations.get(op.property, ()), obs)
        policy = self.ontology.data_property(op.property).resolution
        props = dict(element.properties)
        props[op.property] = resolve_observations(merged, policy)
        observations = dict(element.observations)
        observations[op.property] = merged
        self._emit(ElementPut(self._stamp(element, properties=props, observations=observations)))

    def _remove(self, op: RemoveElement) -> None:
        element = self._need(op.id)
        self._check_rev(element, op.expect_rev)
        doomed = [element.id]
        if op.branch:
            stack = [element.id]
            while stack:
                for rel in self.state.spatial_children(stack.pop()):
                    doomed.append(rel.object)
                    stack.append(rel.object)
        for element_id in reversed(doomed):
            for rel in self.state.relations_of(element_id):
                self._emit(RelationRemoved(rel))
            self._emit(ElementRemoved(element_id))

    def _set_relation(self, rel: Relation) -> None:
        subject, obj = self._need(rel.subject), self._need(rel.object)
        info = self.ontology.check_relation(subject.type, rel.predicate, obj.type)
        if self.state.has_relation(rel):
            return
        if info.spatial:
            self._check_tree(rel)
        existing = [
            (r.predicate, self.state.elements[r.object].type)
            for r in self.state.match_relations(rel.subject)
        ]
        self.ontology.check_max_cardinality(subject.type, rel.predicate, obj.type, existing)
        self._emit(RelationAdded(rel))

    def _check_tree(self, rel: Relation) -> None:
        current = self.state.parent(rel.object)
        if current is not None:
            raise TreeShapeError(
                f"{self._named(rel.object)} already has the spatial parent "
                f"{self._named(current.subject)} ({current.predicate}); unset that relation "
                "first to move it"
            )
        walk: str | None = rel.subject
        while walk is not None:
            if walk == rel.object:
                raise TreeShapeError(
                    f"{rel.predicate}({rel.subject}, {rel.object}) would make a cycle: "
                    f"{self._named(rel.object)} is an ancestor of {self._named(rel.subject)}"
                )
            parent = self.state.parent(walk)
            walk = parent.subject if parent is not None else None
