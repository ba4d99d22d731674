"""The predictive face of conditions: the world-model ops that make post-conditions true.

:func:`effects` plans relation and property changes over the unchanged view and returns them as
ops (unsets first, then sets, then updates), without ops for facts that already hold. Which
conditions predict what is in :mod:`skill_agent.conditions`, the public entry point of
conditions. Pure and synchronous.
"""

from __future__ import annotations

from collections.abc import Sequence

import msgspec

from skill_agent._errors import SkillLoadError, UnspecifiedParameterError
from skill_agent._skill import WorldView
from skill_agent.conditions._model import Bindings, describe, same_value, spatial_relations
from skill_agent.protocol._skills import AndCond, Condition, NotCond, PropertyCond, RelationCond
from wm_store import OntologyError
from wm_store.protocol import Op, Relation, SetRelation, UnsetRelation, UpdateElement, Value

__all__ = ["effects"]


class _Plan:
    """Relation and property changes planned so far, over the unchanged view."""

    def __init__(self, view: WorldView) -> None:
        self.view = view
        self.spatial = spatial_relations(view.ontology)
        self.adds: dict[Relation, None] = {}
        self.removes: dict[Relation, None] = {}
        self.props: dict[str, dict[str, Value]] = {}

    def matching(self, s: str, predicate: str, o: str) -> list[Relation]:
        subs = self.view.ontology.subproperties(predicate) if predicate else None
        now = [r for r in self.view.query_relation(s, predicate, o) if r not in self.removes]
        planned = [
            r
            for r in self.adds
            if (not s or r.subject == s)
            and (not o or r.object == o)
            and (subs is None or r.predicate in subs)
        ]
        return now + planned

    def unset(self, s: str, predicate: str, o: str) -> None:
        for rel in self.matching(s, predicate, o):
            if rel in self.adds:
                del self.adds[rel]
            else:
                self.removes[rel] = None

    def set(self, rel: Relation) -> None:
        info = self.view.ontology.relation(rel.predicate)
        if self.matching(rel.subject, rel.predicate, rel.object):
            return
        if info.abstract:
            raise SkillLoadError(
                f"cannot predict {rel.predicate}({rel.subject}, {rel.object}): "
                f"'{rel.predicate}' is abstract; use one of its sub-properties"
            )
        if rel.predicate in self.spatial:
            for old in self.matching("", "", rel.object):
                if old.predicate in self.spatial:
                    self.unset(old.subject, old.predicate, old.object)
        if rel in self.removes:  # unset by an earlier condition: keep it after all
            del self.removes[rel]
        else:
            self.adds[rel] = None

    def ops(self) -> list[Op]:
        out: list[Op] = [
            UnsetRelation(subject=r.subject, predicate=r.predicate, object=r.object)
            for r in self.removes
        ]
        out += [
            SetRelation(subject=r.subject, predicate=r.predicate, object=r.object)
            for r in self.adds
        ]
        for element_id, wanted in self.props.items():
            element = self.view.find_element(element_id)
            current = {} if element is None else element.properties
            changed = {k: v for k, v in wanted.items() if not same_value(current.get(k), v)}
            if changed:
                out.append(UpdateElement(id=element_id, properties=changed))
        return out


def _bound_id(bindings: Bindings, param: str, cond: Condition) -> str:
    value = bindings.get(param)
    if not isinstance(value, str):
        raise UnspecifiedParameterError(
            f"post-condition {describe(cond)}: parameter '{param}' is {value!r}, not an element "
            "id, so its effect cannot be predicted"
        )
    return value


def _predict(cond: Condition, bindings: Bindings, plan: _Plan) -> None:
    match cond:
        case AndCond(items=items):
            for item in items:
                _predict(item, bindings, plan)
        case NotCond(item=RelationCond() as rel):
            _predict(msgspec.structs.replace(rel, holds=not rel.holds), bindings, plan)
        case RelationCond(subject=s, predicate=p, object=o, holds=holds):
            s_id, o_id = _bound_id(bindings, s, cond), _bound_id(bindings, o, cond)
            if holds:
                plan.set(Relation(s_id, p, o_id))
            else:
                plan.unset(s_id, p, o_id)
        case PropertyCond(param=x, property=q, op="eq", value=v):
            plan.view.ontology.data_property(q)
            plan.props.setdefault(_bound_id(bindings, x, cond), {})[q] = v


def effects(conds: Sequence[Condition], view: WorldView, bindings: Bindings) -> list[Op]:
    """The world-model ops that make the post-conditions ``conds`` true (see
    :mod:`skill_agent.conditions`).

    Raises :class:`~skill_agent.UnspecifiedParameterError` when a predicting condition's
    parameter is unbound, and :class:`~skill_agent.SkillLoadError` for a prediction no
    op can make (an abstract relation, an unknown name)."""
    plan = _Plan(view)
    for cond in conds:
        try:
            _predict(cond, bindings, plan)
        except OntologyError as exc:
            raise SkillLoadError(f"post-condition {describe(cond)}: {exc}") from exc
    return plan.ops()
