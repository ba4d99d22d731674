"""Load-time checks of a skill description: :func:`check_description`.

Every parameter's type is a value kind or a class of the ontology, defaults and partial
definitions fit their parameter, and every condition names parameters, classes, relations and
properties the ontology knows (custom conditions by their registered class).
"""

from __future__ import annotations

from collections.abc import Iterable, Iterator, Mapping
from typing import TYPE_CHECKING

from skill_agent._errors import (
    ParameterTypeError,
    SkillLoadError,
)
from skill_agent.conditions._model import ConditionRegistry, describe
from skill_agent.parameters._specify import VALUE_KINDS, _closest, check_kind, is_value_kind
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
    ParamSpec,
    PropertyCond,
    RelationCond,
    SkillDescription,
)
from wm_store import WmError
from wm_store.ontology import kind_of, with_article
from wm_store.protocol import Pose, Position

if TYPE_CHECKING:
    from wm_store.ontology import Ontology

__all__ = ["check_description"]


def check_description(
    desc: SkillDescription, ontology: Ontology, *, registry: ConditionRegistry | None = None
) -> None:
    """Check a description against the ontology when its skill loads; SkillLoadError lists
    every problem (with the closest known name for each misspelling):

    - parameter names are unique; each type is a value kind or a class; defaults fit;
      hardware parameters are element parameters; a partial definition names known classes,
      properties and relations and can match the parameter's class;
    - conditions refer to existing parameters (element parameters where an element is meant);
      relations, properties and classes exist; custom conditions are registered; a relation's
      or property's parameters can satisfy its domain and range (a swapped subject and object
      fails here); a post-condition does not predict an abstract relation.
    """
    params: dict[str, ParamSpec] = {}
    problems: list[str] = []
    for spec in desc.parameters:
        if spec.name in params:
            problems.append(f"parameter '{spec.name}' is declared twice")
        params[spec.name] = spec
        problems += [f"parameter '{spec.name}': {p}" for p in _param_problems(spec, ontology)]
    checker = _CondChecker(params, ontology, registry)
    for section, conds in (("pre", desc.pre), ("hold", desc.hold), ("post", desc.post)):
        for i, cond in enumerate(conds):
            for problem in checker.problems(cond, post=section == "post"):
                problems.append(f"{section}[{i}] {describe(cond)}: {problem}")
    if problems:
        raise SkillLoadError(
            f"skill '{desc.name}' fails its load checks:\n"
            + "\n".join(f"  - {p}" for p in problems)
        )


def _related(ontology: Ontology, cls: str, allowed: Iterable[str]) -> bool:
    """Whether some element of ``cls`` can belong to one of ``allowed``."""
    return any(ontology.is_a(cls, a) or ontology.is_a(a, cls) for a in allowed)


def _param_problems(spec: ParamSpec, ontology: Ontology) -> Iterator[str]:
    if is_value_kind(spec.type):
        if spec.kind == "hardware":
            yield f"a hardware parameter is a device (a class), not a {spec.type} value"
        if spec.partial is not None:
            yield "a partial definition needs an element parameter (a class type)"
        if spec.default is not None:
            try:
                check_kind(spec, spec.default)
            except ParameterTypeError as exc:
                yield f"bad default: {exc}"
        return
    if spec.type not in ontology.classes:
        hint = _closest(spec.type, ontology.classes | VALUE_KINDS)
        yield (
            f"unknown type '{spec.type}'{hint}; a type is an ontology class or a value kind "
            f"({', '.join(sorted(VALUE_KINDS))})"
        )
        return
    if spec.default is not None and not isinstance(spec.default, str):
        yield f"the default of an element parameter is an element id, not {spec.default!r}"
    q = spec.partial
    if q is None:
        return
    try:
        if q.type and not _related(ontology, ontology.check_class(q.type), [spec.type]):
            yield f"partial type {q.type} can never be {with_article(spec.type)}"
        for f in q.filters:
            ontology.data_property(f.property)
            if f.op in ("eq", "ne") and f.value is not None:
                ontology.check_value(f.property, f.value)
        for rel in q.related:
            ontology.relation(rel.predicate)
            if "?" not in (rel.subject, rel.object):
                yield f"partial relation {rel} needs '?' (the candidate) as subject or object"
    except WmError as exc:
        yield f"partial definition: {exc}"


class _CondChecker:
    def __init__(
        self,
        params: Mapping[str, ParamSpec],
        ontology: Ontology,
        registry: ConditionRegistry | None,
    ) -> None:
        self.params, self.ontology, self.registry = params, ontology, registry

    def param(self, name: str) -> Iterator[str]:
        if name not in self.params:
            hint = _closest(name, self.params)
            yield f"unknown parameter '{name}'{hint}; parameters: {', '.join(self.params)}"

    def element(self, name: str) -> tuple[str | None, list[str]]:
        """The class of element parameter ``name`` (None if unusable) and the problems."""
        problems = list(self.param(name))
        spec = self.params.get(name)
        if spec is None or spec.type not in self.ontology.classes:
            if spec is not None and is_value_kind(spec.type):
                problems.append(f"parameter '{name}' is a {spec.type} value, not an element")
            return None, problems
        return spec.type, problems

    def fits(self, name: str, roles: Mapping[str, Iterable[str]]) -> Iterator[str]:
        """Problems of element parameter ``name`` in each role (-> the classes it allows)."""
        cls, problems = self.element(name)
        yield from problems
        if cls is None:
            return
        for role, allowed in roles.items():
            names = sorted(allowed)
            if names and not _related(self.ontology, cls, names):
                yield f"{role} must be {' or '.join(names)}; '{name}' is {with_article(cls)}"

    def problems(self, cond: Condition, *, post: bool) -> Iterator[str]:
        onto = self.ontology
        try:
            match cond:
                case AndCond(items=items) | OrCond(items=items):
                    for item in items:
                        yield from self.problems(item, post=post)
                case NotCond(item=item):
                    yield from self.problems(item, post=post)
                case IsSpecifiedCond(param=x):
                    yield from self.param(x)
                case CustomCond(name=name, params=names):
                    try:
                        (self.registry or ConditionRegistry()).get(name)
                    except SkillLoadError as exc:
                        yield str(exc)
                    for x in names:
                        yield from self.param(x)
                case RelationCond(subject=s, predicate=p, object=o, holds=holds):
                    info, chain = onto.relation(p), sorted(onto.superproperties(p))
                    subject = {f"the subject of '{r}'": onto.relation(r).domains for r in chain}
                    yield from self.fits(s, subject)
                    obj = {f"the object of '{r}'": onto.relation(r).ranges for r in chain}
                    yield from self.fits(o, obj)
                    if post and holds and info.abstract:
                        subs = sorted(onto.subproperties(p) - {p})
                        yield f"'{p}' is abstract, so no effect can make it true; use one of {subs}"
                case PropertyCond(param=x, property=q) | HasPropertyCond(param=x, property=q):
                    domains = onto.data_property(q).domains
                    yield from self.fits(x, {f"the element of property '{q}'": domains})
                    if isinstance(cond, PropertyCond):
                        yield from _value_problems(cond, onto)
                case IsTypeCond(param=x, cls=cls):
                    target = onto.check_class(cls)
                    have, found = self.element(x)
                    yield from found
                    if have is not None and not _related(onto, have, [target]):
                        yield f"'{x}' is {with_article(have)}, never {with_article(target)}"
                case EmptyCond(param=x, predicate=p):
                    onto.relation(p)
                    yield from self.element(x)[1]
        except WmError as exc:
            yield str(exc)


def _value_problems(cond: PropertyCond, ontology: Ontology) -> Iterator[str]:
    v = cond.value
    if cond.op in ("eq", "ne") and v is not None:
        ontology.check_value(cond.property, v)
    elif cond.op in ("lt", "le", "gt", "ge") and kind_of(v) not in ("int", "float", "string"):
        yield f"'{cond.op}' compares numbers or strings, not {v!r}"
    elif cond.op == "near":
        if not (kind_of(v) in ("int", "float") or isinstance(v, Pose | Position)):
            yield f"'near' compares numbers, positions or poses, not {v!r}"
        if cond.tolerance < 0:
            yield f"tolerance {cond.tolerance} is negative"
