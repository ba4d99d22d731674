"""What every face of a condition shares: verdicts, planner atoms, custom conditions, names.

:class:`Verdict` is what evaluation answers, :class:`Atom` what the planner sees; a
:class:`CustomCondition` is a class registered by name in a :class:`ConditionRegistry` (one per
agent, no process-global registry). The faces that need no world model live here too:
:func:`describe` (text), :func:`parameters_of` and :func:`symbolic` (planner atoms; the table is
in :mod:`skill_agent.conditions`, the public entry point of conditions; :func:`value_text` names
the values in atoms). Pure and synchronous.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from typing import TYPE_CHECKING, ClassVar, Protocol, TypeAlias

import msgspec

from skill_agent._errors import SkillLoadError
from skill_agent._skill import WorldView
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
from wm_store.ontology import did_you_mean, with_article
from wm_store.protocol import Value

if TYPE_CHECKING:
    from wm_store.ontology import Ontology

__all__ = [
    "OP_TEXT",
    "Atom",
    "Bindings",
    "ConditionRegistry",
    "CustomCondition",
    "Verdict",
    "describe",
    "parameters_of",
    "same_value",
    "spatial_relations",
    "symbolic",
    "value_text",
]

Bindings: TypeAlias = Mapping[str, Value]
"""Parameter name -> value; element parameters hold element ids."""

OP_TEXT = {"eq": "==", "ne": "!=", "lt": "<", "le": "<=", "gt": ">", "ge": ">="}
"""Comparators as :func:`describe` and verdicts write them."""


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


def same_value(a: Value, b: Value) -> bool:
    """Equality that keeps bools apart from numbers (``True != 1`` here)."""
    return isinstance(a, bool) == isinstance(b, bool) and a == b


def spatial_relations(ontology: Ontology) -> frozenset[str]:
    """The names of the ontology's spatial relations."""
    return frozenset(name for name, info in ontology.relations.items() if info.spatial)


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
            return f"{x}.{q} {OP_TEXT[op]} {v!r}"
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


# --------------------------------------------------------------------------- symbolic


def value_text(value: Value) -> str | None:
    """A property value as atoms name it (``true``, ``3``, ``abc``); None if not symbolic."""
    if isinstance(value, bool):
        return "true" if value else "false"
    if isinstance(value, int | str):
        return str(value)
    return None


def symbolic(cond: Condition, *, registry: ConditionRegistry | None = None) -> list[Atom] | None:
    """The atoms the planner sees for ``cond`` (the table in :mod:`skill_agent.conditions`);
    None: run time only."""
    match cond:
        case RelationCond(subject=s, predicate=p, object=o, holds=holds):
            return [Atom(p, (s, o), holds)]
        case PropertyCond(param=x, property=q, op="exists"):
            return [Atom(f"has_{q}", (x,))]
        case PropertyCond(param=x, property=q, op="eq" | "ne" as op, value=v):
            text = value_text(v)
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
