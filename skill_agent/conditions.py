"""Conditions of skills: evaluation against the world model, predicted effects, planner atoms.

A condition (``skill_agent.protocol.Condition``) is data with four faces:

``evaluate(cond, view, bindings)``
    Run time: a :class:`Verdict` (``ok`` and a reason a person understands, for true *and*
    false). Relation predicates include their sub-properties (``spatialRelation`` matches
    ``contain`` and ``hasA``). Leaf conditions presuppose their elements: a leaf whose parameter
    is unbound, not an element id, or names an element missing from the world model is false
    (also with ``holds=False``); only ``NotCond`` turns that into true, so prefer
    ``holds=False`` when "the box exists and does not contain the gear" is meant. A condition
    naming a class, relation or property the view's ontology lacks is false with the
    ontology's message (:func:`skill_agent.params.check_description` rejects it at load).
    Property comparisons: ``eq None`` means "absent", a missing property is ``ne`` anything
    else, ``lt``..``ge`` compare two numbers or two strings (a bool is not a number: never
    ``True == 1``), ``near`` two numbers or two positions/poses in the same frame. ``full``
    counts against the ``capacity`` property, else the ontology's maximum cardinality (a
    Gripper holds one thing), else the container is never full.
``effects(conds, view, bindings)``
    The prediction: world-model ops making post-conditions true, without ops for facts that
    already hold. ``RelationCond`` -> ``SetRelation`` (a spatial predicate first unsets the
    object's current spatial parent) or, with ``holds=False``, ``UnsetRelation`` of every
    matching relation (sub-properties included); ``PropertyCond`` ``eq`` -> ``UpdateElement``
    (``eq None`` deletes the property); ``AndCond`` -> its items; ``NotCond`` of a relation ->
    the opposite relation effect. Everything else is checked only. Later conditions win over
    earlier contradicting ones; unsets come first in the list, then sets, then updates.
``symbolic(cond)``
    The planner's view: a conjunction of :class:`Atom` over *parameter names*, or ``None``
    when the condition is run-time only. The task layer turns these into PDDL:

    ========================================  =========================================
    condition                                 atoms
    ========================================  =========================================
    RelationCond(s, p, o, holds)              ``p(s, o)``, positive = holds
    PropertyCond(x, q, eq, v) v bool/int/str  ``q=v(x)`` (bools as true/false)
    PropertyCond(x, q, ne, v) v bool/int/str  ``q=v(x)`` negative
    PropertyCond(x, q, exists)                ``has_q(x)``
    PropertyCond lt/le/gt/ge/near, float v    None (numeric: run time only)
    HasPropertyCond(x, q, holds)              ``has_q(x)``, positive = holds
    IsTypeCond(x, C)                          ``is_C(x)`` (static; subclasses count)
    EmptyCond(x, p, holds)                    ``empty_p(x)``, positive = holds (derived:
                                              no ``p(x, ?o)``)
    EmptyCond(..., full=True)                 None (needs counting)
    IsSpecifiedCond(x)                        [] (the planner binds every parameter)
    CustomCond(name, ...)                     the registered class's ``symbolic``, or None
    AndCond(items)                            all items' atoms; None if any item is None
    OrCond(items)                             one item: its atoms; else None
    NotCond(item)                             the item's single atom negated; else None
    ========================================  =========================================
``parameters_of(cond)``
    The parameter names a condition refers to (what inference and load checks use).

Custom conditions are classes registered by name in a :class:`ConditionRegistry`, one per
agent (no process-global registry). Everything here is pure and synchronous.
"""

from __future__ import annotations

import math
import operator
from collections.abc import Callable, Mapping, Sequence
from typing import Any, ClassVar, Protocol, TypeAlias

import msgspec

from wm_store.errors import OntologyError
from wm_store.ontology import Ontology
from wm_store.ontology_model import did_you_mean, with_article
from wm_store.protocol import (
    Element,
    Op,
    Pose,
    Position,
    Relation,
    SetRelation,
    UnsetRelation,
    UpdateElement,
    Value,
)

from .errors import SkillLoadError, UnspecifiedParameterError
from .protocol import (
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
from .skill import WorldView

__all__ = [
    "Atom",
    "Bindings",
    "ConditionRegistry",
    "CustomCondition",
    "Verdict",
    "describe",
    "effects",
    "evaluate",
    "evaluate_all",
    "parameters_of",
    "symbolic",
]

Bindings: TypeAlias = Mapping[str, Value]
"""Parameter name -> value; element parameters hold element ids."""

_OP_TEXT = {"eq": "==", "ne": "!=", "lt": "<", "le": "<=", "gt": ">", "ge": ">="}
_ORDER: dict[str, Callable[[Any, Any], Any]] = {
    "lt": operator.lt,
    "le": operator.le,
    "gt": operator.gt,
    "ge": operator.ge,
}


class Verdict(msgspec.Struct, frozen=True):
    """The truth of a condition, and why (for a true verdict too)."""

    ok: bool
    reason: str


class Atom(msgspec.Struct, frozen=True):
    """A ground-able planner fact: ``predicate(*args)`` over parameter names."""

    predicate: str
    args: tuple[str, ...]
    positive: bool = True


class CustomCondition(Protocol):
    """A condition class registered by ``name`` (used through ``CustomCond``)."""

    name: ClassVar[str]

    def evaluate(
        self, view: WorldView, bindings: Bindings, params: Sequence[str], args: Mapping[str, Value]
    ) -> Verdict: ...

    def symbolic(self, params: Sequence[str], args: Mapping[str, Value]) -> list[Atom] | None: ...


class ConditionRegistry:
    """Custom conditions by name; one per agent (plug-ins register into it at load)."""

    def __init__(self) -> None:
        self._by_name: dict[str, CustomCondition] = {}

    def register(
        self, condition: type[CustomCondition] | CustomCondition, *, replace: bool = False
    ) -> None:
        """Register a class (instantiated with no arguments) or a configured instance.
        A second, different condition under a taken name is refused unless ``replace``."""
        instance = condition() if isinstance(condition, type) else condition
        name = instance.name
        old = self._by_name.get(name)
        if old is not None and type(old) is not type(instance) and not replace:
            raise SkillLoadError(
                f"custom condition {name!r} is already registered by {type(old).__qualname__}; "
                "pick another name or pass replace=True"
            )
        self._by_name[name] = instance

    def get(self, name: str) -> CustomCondition:
        try:
            return self._by_name[name]
        except KeyError:
            raise SkillLoadError(
                f"unknown custom condition {name!r}{did_you_mean(name, self._by_name)} "
                f"Registered: {sorted(self._by_name) or 'none'}"
            ) from None

    def __contains__(self, name: object) -> bool:
        return name in self._by_name

    def names(self) -> list[str]:
        return sorted(self._by_name)


# --------------------------------------------------------------------------- describing


def describe(cond: Condition) -> str:
    """A compact text form, e.g. ``contain(box, gear)`` or ``gear.mass > 0.3``."""
    match cond:
        case RelationCond(subject=s, predicate=p, object=o, holds=holds):
            return f"{'' if holds else 'not '}{p}({s}, {o})"
        case PropertyCond(param=x, property=q, op=op, value=v, tolerance=tol):
            if op == "exists":
                return f"{x}.{q} exists"
            if op == "near":
                return f"{x}.{q} within {tol} of {v!r}"
            return f"{x}.{q} {_OP_TEXT[op]} {v!r}"
        case HasPropertyCond(param=x, property=q, holds=holds):
            return f"{'has' if holds else 'lacks'} {x}.{q}"
        case IsTypeCond(param=x, cls=cls):
            return f"{x} is {with_article(cls)}"
        case EmptyCond(param=x, predicate=p, holds=holds, full=full):
            what = "full" if full else "empty"
            return f"{'' if holds else 'not '}{what}({x}{'' if p == 'contain' else ', ' + p})"
        case IsSpecifiedCond(param=x):
            return f"specified({x})"
        case CustomCond(name=name, params=params, args=args):
            inner = ", ".join([*params, *(f"{k}={v!r}" for k, v in args.items())])
            return f"{name}({inner})"
        case AndCond(items=items):
            return "(" + " and ".join(describe(i) for i in items) + ")"
        case OrCond(items=items):
            return "(" + " or ".join(describe(i) for i in items) + ")"
        case NotCond(item=item):
            return f"not {describe(item)}"


def parameters_of(cond: Condition) -> set[str]:
    """The parameter names ``cond`` refers to."""
    match cond:
        case RelationCond(subject=s, object=o):
            return {s, o}
        case CustomCond(params=params):
            return set(params)
        case AndCond(items=items) | OrCond(items=items):
            return set().union(*(parameters_of(i) for i in items))
        case NotCond(item=item):
            return parameters_of(item)
        case _:
            return {cond.param}


# --------------------------------------------------------------------------- evaluation


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


def _spatial(ontology: Ontology) -> frozenset[str]:
    return frozenset(name for name, info in ontology.relations.items() if info.spatial)


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
    where, spatial = "", _spatial(view.ontology)
    if cond.predicate in spatial or view.ontology.relation(cond.predicate).abstract:
        parents = [r for r in view.query_relation(obj=o) if r.predicate in spatial]
        if parents:
            where = f": {o}'s spatial parent is {parents[0].subject} ({parents[0].predicate})"
    return Verdict(False, f"{fact} does not hold{where}")


def _same(a: Value, b: Value) -> bool:
    """Equality that keeps bools apart from numbers (``True != 1`` here)."""
    return isinstance(a, bool) == isinstance(b, bool) and a == b


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
        return _same(have, want)
    if op == "ne":
        return not _same(have, want)
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
    want = f"{_OP_TEXT[cond.op]} {cond.value!r}"
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


# --------------------------------------------------------------------------- effects


class _Plan:
    """Relation and property changes planned so far, over the unchanged view."""

    def __init__(self, view: WorldView) -> None:
        self.view = view
        self.spatial = _spatial(view.ontology)
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
            changed = {k: v for k, v in wanted.items() if not _same(current.get(k), v)}
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
    """The world-model ops that make the post-conditions ``conds`` true (see the module doc).

    Raises :class:`~skill_agent.errors.UnspecifiedParameterError` when a predicting condition's
    parameter is unbound, and :class:`~skill_agent.errors.SkillLoadError` for a prediction no
    op can make (an abstract relation, an unknown name)."""
    plan = _Plan(view)
    for cond in conds:
        try:
            _predict(cond, bindings, plan)
        except OntologyError as exc:
            raise SkillLoadError(f"post-condition {describe(cond)}: {exc}") from exc
    return plan.ops()


# --------------------------------------------------------------------------- symbolic


def _literal(value: Value) -> str | None:
    if isinstance(value, bool):
        return "true" if value else "false"
    if isinstance(value, int | str):
        return str(value)
    return None


def symbolic(cond: Condition, *, registry: ConditionRegistry | None = None) -> list[Atom] | None:
    """The atoms the planner sees for ``cond`` (table in the module doc); None: run time only."""
    match cond:
        case RelationCond(subject=s, predicate=p, object=o, holds=holds):
            return [Atom(p, (s, o), holds)]
        case PropertyCond(param=x, property=q, op="exists"):
            return [Atom(f"has_{q}", (x,))]
        case PropertyCond(param=x, property=q, op="eq" | "ne" as op, value=v):
            text = _literal(v)
            return None if text is None else [Atom(f"{q}={text}", (x,), op == "eq")]
        case HasPropertyCond(param=x, property=q, holds=holds):
            return [Atom(f"has_{q}", (x,), holds)]
        case IsTypeCond(param=x, cls=cls):
            return [Atom(f"is_{cls}", (x,))]
        case EmptyCond(param=x, predicate=p, holds=holds, full=False):
            return [Atom(f"empty_{p}", (x,), holds)]
        case IsSpecifiedCond():
            return []
        case CustomCond(name=name, params=params, args=args):
            if registry is None or name not in registry:
                return None
            return registry.get(name).symbolic(params, args)
        case AndCond(items=items):
            atoms: list[Atom] = []
            for item in items:
                part = symbolic(item, registry=registry)
                if part is None:
                    return None
                atoms += part
            return atoms
        case OrCond(items=[single]):
            return symbolic(single, registry=registry)
        case NotCond(item=item):
            part = symbolic(item, registry=registry)
            if part is None or len(part) != 1:
                return None
            return [msgspec.structs.replace(part[0], positive=not part[0].positive)]
    return None
