"""The run-time face of conditions: is a condition true in the world model, and why.

:func:`evaluate` answers a :class:`~skill_agent.conditions.Verdict` with a reason a person
understands, for true and false alike; :func:`evaluate_all` checks a list and stops at the first
false one. The semantics (leaf conditions presuppose their elements, property comparisons,
``full`` and capacities) are in :mod:`skill_agent.conditions`, the public entry point of
conditions. Pure and synchronous.
"""

from __future__ import annotations

import math
import operator
from collections.abc import Callable, Sequence
from typing import TYPE_CHECKING, Any

from skill_agent._errors import SkillLoadError
from skill_agent._skill import WorldView
from skill_agent.conditions._model import (
    OP_TEXT,
    Bindings,
    ConditionRegistry,
    Verdict,
    describe,
    same_value,
    spatial_relations,
)
from skill_agent.protocol._skills import (
    AndCond,
    Condition,
    CustomCond,
    EmptyCond,
    HasPropertyCond,
    IsSpecifiedCond,
    IsTypeCond,
    NotCond,
    OrCond,
    PropertyCond,
    RelationCond,
)
from wm_store import OntologyError
from wm_store.ontology import with_article
from wm_store.protocol import Element, Pose, Position, Value

if TYPE_CHECKING:
    from wm_store.ontology import Ontology

__all__ = ["evaluate", "evaluate_all"]

_ORDER: dict[str, Callable[[Any, Any], Any]] = {
    "lt": operator.lt,
    "le": operator.le,
    "gt": operator.gt,
    "ge": operator.ge,
}


def evaluate(
    cond: Condition,
    view: WorldView,
    bindings: Bindings,
    *,
    registry: ConditionRegistry | None = None,
) -> Verdict:
    """Whether ``cond`` holds in ``view`` with these parameter values, and why."""
    try:
        return _evaluate(cond, view, bindings, registry)
    except OntologyError as exc:
        return Verdict(False, f"invalid condition {describe(cond)}: {exc}")


def evaluate_all(
    conds: Sequence[Condition],
    view: WorldView,
    bindings: Bindings,
    *,
    registry: ConditionRegistry | None = None,
) -> Verdict:
    """The first false condition's verdict, or ok with every reason."""
    reasons = []
    for cond in conds:
        verdict = evaluate(cond, view, bindings, registry=registry)
        if not verdict.ok:
            return verdict
        reasons.append(verdict.reason)
    return Verdict(True, f"all {len(reasons)} conditions hold" + "".join(f"; {r}" for r in reasons))


def _lookup(view: WorldView, bindings: Bindings, param: str) -> Element | str:
    """The element bound to ``param``, or why there is none."""
    value = bindings.get(param)
    if value is None:
        return f"parameter '{param}' is not specified"
    if not isinstance(value, str):
        return f"parameter '{param}' is {value!r}, not an element id"
    return view.find_element(value) or f"{value} (parameter '{param}') is not in the world model"


def _evaluate(
    cond: Condition, view: WorldView, bindings: Bindings, registry: ConditionRegistry | None
) -> Verdict:
    match cond:
        case IsSpecifiedCond(param=x):
            value = bindings.get(x)
            if value is None:
                return Verdict(False, f"parameter '{x}' is not specified")
            return Verdict(True, f"parameter '{x}' is specified ({value!r})")
        case CustomCond(name=name, params=params, args=args):
            if registry is None:
                return Verdict(False, f"custom condition {name!r}: no condition registry given")
            try:
                custom = registry.get(name)
            except SkillLoadError as exc:
                return Verdict(False, str(exc))
            return custom.evaluate(view, bindings, params, args)
        case AndCond(items=items):
            reasons = []
            for item in items:
                verdict = _evaluate(item, view, bindings, registry)
                if not verdict.ok:
                    return verdict
                reasons.append(verdict.reason)
            return Verdict(True, " and ".join(reasons) or "empty conjunction (true)")
        case OrCond(items=items):
            reasons = []
            for item in items:
                verdict = _evaluate(item, view, bindings, registry)
                if verdict.ok:
                    return verdict
                reasons.append(verdict.reason)
            return Verdict(False, "none holds: " + " | ".join(reasons) if reasons else "empty or")
        case NotCond(item=item):
            inner = _evaluate(item, view, bindings, registry)
            if inner.ok:
                return Verdict(False, f"{inner.reason}; expected the opposite")
            return Verdict(True, f"negation holds: {inner.reason}")
        case RelationCond():
            return _relation(cond, view, bindings)
    element = _lookup(view, bindings, cond.param)
    if isinstance(element, str):
        return Verdict(False, element)
    match cond:
        case PropertyCond():
            return _property(cond, view.ontology, element)
        case HasPropertyCond(property=q, holds=holds):
            view.ontology.data_property(q)
            have = element.properties.get(q)
            text = f"{element.id} has no {q!r}" if have is None else f"{element.id}.{q} is {have!r}"
            ok = (have is not None) == holds
            return Verdict(ok, text if ok else f"{text}, expected {'it' if holds else 'none'}")
        case IsTypeCond(cls=cls):
            is_it = view.ontology.is_a(element.type, view.ontology.check_class(cls))
            text = f"{element.id} is {with_article(element.type)}"
            if not is_it:
                return Verdict(False, f"{text}, expected {with_article(cls)}")
            return Verdict(True, text if element.type == cls else f"{text}, so {with_article(cls)}")
        case EmptyCond():
            return _empty(cond, view, element)
    raise TypeError(f"not a condition: {cond!r}")  # pragma: no cover - exhaustive


def _relation(cond: RelationCond, view: WorldView, bindings: Bindings) -> Verdict:
    found: list[Element] = []
    for param in (cond.subject, cond.object):
        element = _lookup(view, bindings, param)
        if isinstance(element, str):
            return Verdict(False, element)
        found.append(element)
    s, o = found[0].id, found[1].id
    fact = f"{cond.predicate}({s}, {o})"
    matches = view.query_relation(s, cond.predicate, o)
    if matches:
        via = matches[0].predicate
        text = f"{fact} holds" + ("" if via == cond.predicate else f" (as {via})")
        return Verdict(cond.holds, text if cond.holds else f"{text}, expected not")
    if not cond.holds:
        return Verdict(True, f"{fact} does not hold")
    where, spatial = "", spatial_relations(view.ontology)
    if cond.predicate in spatial or view.ontology.relation(cond.predicate).abstract:
        parents = [r for r in view.query_relation(obj=o) if r.predicate in spatial]
        if parents:
            where = f": {o}'s spatial parent is {parents[0].subject} ({parents[0].predicate})"
    return Verdict(False, f"{fact} does not hold{where}")


def _point(v: Value) -> tuple[tuple[float, float, float], str] | None:
    if isinstance(v, Pose):
        return (v.position.x, v.position.y, v.position.z), v.frame or v.position.frame
    if isinstance(v, Position):
        return (v.x, v.y, v.z), v.frame
    return None


def _distance(a: Value, b: Value) -> float | None:
    """Distance of two numbers, or of two positions/poses in the same frame; else None."""
    if isinstance(a, int | float) and isinstance(b, int | float):
        if isinstance(a, bool) or isinstance(b, bool):
            return None
        return abs(float(a) - float(b))
    pa, pb = _point(a), _point(b)
    if pa is None or pb is None or pa[1] != pb[1]:
        return None
    return math.dist(pa[0], pb[0])


def _compare(op: str, have: Value, want: Value) -> bool:
    if op == "eq":
        return same_value(have, want)
    if op == "ne":
        return not same_value(have, want)
    if isinstance(have, str) and isinstance(want, str):
        return bool(_ORDER[op](have, want))
    if _number(have) and _number(want):
        return bool(_ORDER[op](have, want))
    return False  # missing, or not comparable (a bool, a typed value, a list)


def _number(v: Value) -> bool:
    return isinstance(v, int | float) and not isinstance(v, bool)


def _property(cond: PropertyCond, ontology: Ontology, element: Element) -> Verdict:
    ontology.data_property(cond.property)
    have = element.properties.get(cond.property)
    state = (
        f"{element.id} has no {cond.property!r}"
        if have is None
        else f"{element.id}.{cond.property} is {have!r}"
    )
    if cond.op == "exists":
        return Verdict(have is not None, state if have is not None else f"{state}, expected one")
    if cond.op == "near":
        d = _distance(have, cond.value)
        want = f"within {cond.tolerance} of {cond.value!r}"
        if d is None:
            return Verdict(False, f"{state}, not comparable with {cond.value!r}; expected {want}")
        ok = d <= cond.tolerance
        return Verdict(ok, f"{state}, {d:.4g} away; {'' if ok else 'expected '}{want}")
    want = f"{OP_TEXT[cond.op]} {cond.value!r}"
    ok = _compare(cond.op, have, cond.value)
    return Verdict(ok, f"{state}, {'as required' if ok else 'expected'} {want}")


def _capacity(element: Element, predicate: str, ontology: Ontology) -> tuple[int | None, str]:
    cap = element.properties.get("capacity")
    if isinstance(cap, int) and not isinstance(cap, bool):
        return cap, "its 'capacity'"
    bound = ontology.max_cardinality(element.type, predicate)
    return bound, f"the ontology's maximum for {with_article(element.type)}"


def _empty(cond: EmptyCond, view: WorldView, element: Element) -> Verdict:
    items = [r.object for r in view.query_relation(element.id, cond.predicate)]
    n = len(items)
    listing = ", ".join(items[:5]) + (f" and {n - 5} more" if n > 5 else "")
    verb = "contains" if cond.predicate == "contain" else cond.predicate
    if not cond.full:
        is_empty = n == 0
        text = f"{element.id} is empty" if is_empty else f"{element.id} {verb} {listing}"
        ok = is_empty == cond.holds
        return Verdict(ok, text if ok else f"{text}, expected {'' if cond.holds else 'not '}empty")
    cap, source = _capacity(element, cond.predicate, view.ontology)
    if cap is None:
        text = f"{element.id} holds {n} ({cond.predicate}) and has no capacity (no 'capacity' "
        text += "property, no maximum in the ontology), so it is never full"
        return Verdict(not cond.holds, text if not cond.holds else f"{text}; expected full")
    is_full = n >= cap
    text = f"{element.id} holds {n} of {cap} ({source}): {'full' if is_full else 'not full'}"
    ok = is_full == cond.holds
    return Verdict(ok, text if ok else f"{text}, expected {'' if cond.holds else 'not '}full")
