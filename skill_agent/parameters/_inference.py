"""Inference of unspecified element parameters, used by :func:`skill_agent.parameters.specify`.

Each unspecified element parameter has a *domain*: the elements of its class (subclasses
included) that match its partial definition. Parameters are inferred most-constrained first
(fewest candidates; ties in declaration order). For one parameter, every candidate is ranked by

1. the number of *applicable* pre-conditions that hold, descending: those that involve this
   parameter and otherwise only parameters already specified (given, defaulted or inferred
   before it);
2. the distance to the robot, ascending, when the robot and the candidate both have a pose
   (a candidate with a pose ranks before one without);
3. natural id order (``Gear-2`` before ``Gear-10``).

Only a candidate whose applicable pre-conditions all hold is chosen. If a choice leaves a later
parameter without a viable candidate, the search backtracks to the next one (bounded by
:data:`BUDGET` trials), so inference never settles for a dead end that another choice avoids.
Every choice comes with a reason naming the winner, the runner-up and what decided between
them; no candidate raises :class:`~skill_agent.InferenceError` saying why each kind of
candidate was rejected. Nothing is cached: each call reads the world model as it is now.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from typing import NamedTuple

import msgspec

from skill_agent._errors import InferenceError
from skill_agent._skill import WorldView
from skill_agent.conditions._eval import evaluate
from skill_agent.conditions._model import ConditionRegistry, parameters_of
from skill_agent.protocol._skills import ParamSpec, SkillDescription
from wm_store.ontology import with_article
from wm_store.protocol import Element, Pose, Position, Query, Value
from wm_store.reasoners import Transform
from wm_store.scene import id_sort_key

__all__ = ["BUDGET", "describe_query", "domain", "infer", "matching", "world_position"]

BUDGET = 500
"""Candidate trials one :func:`infer` call may make before it gives up."""


def describe_query(query: Query) -> str:
    """A partial definition as text, e.g. ``label 'big', mass > 0.3, contain(Box-1, ?)``."""
    ops = {"eq": "==", "ne": "!=", "lt": "<", "le": "<=", "gt": ">", "ge": ">="}
    parts = [f"type {query.type}"] if query.type else []
    parts += [f"label {query.label!r}"] if query.label else []
    for f in query.filters:
        if f.op == "exists":
            parts.append(f"has {f.property}")
        elif f.op == "near":
            parts.append(f"{f.property} within {f.tolerance} of {f.value!r}")
        else:
            parts.append(f"{f.property} {ops[f.op]} {f.value!r}")
    parts += [f"{r.predicate}({r.subject}, {r.object})" for r in query.related]
    return ", ".join(parts) or "no constraints"


def _local(element: Element) -> tuple[Transform, str] | None:
    pose, position = element.properties.get("pose"), element.properties.get("position")
    if isinstance(pose, Pose):
        p, o = pose.position, pose.orientation
        n = math.sqrt(o.x * o.x + o.y * o.y + o.z * o.z + o.w * o.w)
        if not n or not math.isfinite(n):
            return None
        quat = (o.x / n, o.y / n, o.z / n, o.w / n)
        return Transform((p.x, p.y, p.z), quat), pose.frame or p.frame
    if isinstance(position, Position):
        return Transform((position.x, position.y, position.z)), position.frame
    return None


def world_position(view: WorldView, element_id: str) -> tuple[float, float, float] | None:
    """The element's position in the world, chaining ``pose``/``position`` frames; None when
    a pose along the chain is missing, names no element, or the frames form a cycle."""
    chain: Transform | None = None
    current, seen = element_id, set[str]()
    while current:
        element = view.find_element(current)
        local = None if current in seen or element is None else _local(element)
        if local is None:
            return None
        seen.add(current)
        transform, current = local
        chain = transform if chain is None else transform.compose(chain)
    return None if chain is None else chain.translation


def matching(view: WorldView, spec: ParamSpec) -> list[str]:
    """Ids of the elements of the parameter's class (subclasses included) that match its
    partial definition, in natural order."""
    query = spec.partial or Query()
    found = view.resolve_element(msgspec.structs.replace(query, type=query.type or spec.type))
    return [e.id for e in found if view.ontology.is_a(e.type, spec.type)]


def domain(view: WorldView, spec: ParamSpec, skill: str) -> list[str]:
    """:func:`matching`, or InferenceError saying whether the class or the partial definition
    left no candidate."""
    ids = matching(view, spec)
    if ids:
        return ids
    of_class = [e.id for e in view.resolve_element(type=spec.type)]
    head = f"cannot infer parameter '{spec.name}' ({with_article(spec.type)}) of skill '{skill}'"
    if not of_class:
        why = f"the world model has no {spec.type} (nor an element of a subclass)"
    else:
        partial = describe_query(spec.partial or Query())
        are = "is a" if len(of_class) == 1 else "are"
        why = f"{_listing(of_class)} {are} {spec.type} but none matches its partial definition"
        why += f" ({partial})"
    raise InferenceError(f"{head}: {why}. Give '{spec.name}' explicitly")


def _listing(ids: Sequence[str], limit: int = 5) -> str:
    shown = ", ".join(ids[:limit])
    return shown + (f" and {len(ids) - limit} more" if len(ids) > limit else "")


class _Candidate(NamedTuple):
    id: str
    held: int
    failure: str
    """The first applicable pre-condition that is false ("" if none: viable)."""
    distance: float | None


class _DeadEnd(NamedTuple):
    param: str
    why: str


class _Search:
    def __init__(
        self,
        desc: SkillDescription,
        view: WorldView,
        robot: str | None,
        registry: ConditionRegistry | None,
    ) -> None:
        self.desc, self.view, self.robot, self.registry = desc, view, robot, registry
        self.origin = None if robot is None else world_position(view, robot)
        self.trials = 0
        self.reasons: dict[str, str] = {}

    def rank(
        self, spec: ParamSpec, ids: list[str], assigned: Mapping[str, Value]
    ) -> list[_Candidate]:
        known = {name for name, value in assigned.items() if value is not None} | {spec.name}
        conds = []
        for cond in self.desc.pre:
            names = parameters_of(cond)
            if spec.name in names and names <= known:
                conds.append(cond)
        out = []
        for cid in ids:
            bindings = {**assigned, spec.name: cid}
            verdicts = [evaluate(c, self.view, bindings, registry=self.registry) for c in conds]
            failure = next((v.reason for v in verdicts if not v.ok), "")
            here = None if self.origin is None else world_position(self.view, cid)
            distance = None if here is None or self.origin is None else math.dist(here, self.origin)
            out.append(_Candidate(cid, sum(v.ok for v in verdicts), failure, distance))
        out.sort(key=lambda c: (-c.held, c.distance is None, c.distance or 0.0, id_sort_key(c.id)))
        return out

    def solve(
        self,
        order: Sequence[ParamSpec],
        domains: Mapping[str, list[str]],
        assigned: Mapping[str, Value],
    ) -> dict[str, str] | _DeadEnd:
        if not order:
            return {}
        spec, rest = order[0], order[1:]
        ranking = self.rank(spec, domains[spec.name], assigned)
        viable = [c for c in ranking if not c.failure]
        if not viable:
            fails = "; ".join(f"{c.id}: {c.failure}" for c in ranking[:5])
            more = f" (and {len(ranking) - 5} more)" if len(ranking) > 5 else ""
            return _DeadEnd(spec.name, f"every candidate fails a pre-condition: {fails}{more}")
        dead: list[tuple[str, _DeadEnd]] = []
        for cand in viable:
            self.trials += 1
            if self.trials > BUDGET:
                raise InferenceError(
                    f"skill '{self.desc.name}': inference gave up after {BUDGET} trials "
                    f"without finding values of {', '.join(s.name for s in order)} for which "
                    "every pre-condition holds; give some of them explicitly"
                )
            found = self.solve(rest, domains, {**assigned, spec.name: cand.id})
            if not isinstance(found, _DeadEnd):
                self.reasons[spec.name] = self.explain(spec, cand, ranking, dead)
                return {spec.name: cand.id, **found}
            dead.append((cand.id, found))
        tried = ", ".join(cid for cid, _ in dead)
        first = dead[0][1]
        return _DeadEnd(first.param, f"{first.why} (tried {spec.name} = {tried})")

    def explain(
        self,
        spec: ParamSpec,
        chosen: _Candidate,
        ranking: list[_Candidate],
        dead: list[tuple[str, _DeadEnd]],
    ) -> str:
        if len(ranking) == 1:
            return f"{chosen.id}: the only {spec.type} candidate"
        head = f"{chosen.id}: chosen from {len(ranking)} {spec.type} candidates"
        if dead:
            skipped = "; ".join(
                f"{cid} ranked higher, but then '{d.param}' has no viable candidate: {d.why}"
                for cid, d in dead
            )
            return f"{head}; {skipped}"
        runner = ranking[1]
        return f"{head}; runner-up {runner.id}; decided by {self.criterion(chosen, runner)}"

    def criterion(self, a: _Candidate, b: _Candidate) -> str:
        if a.held != b.held:
            return f"pre-conditions ({b.id}: {b.failure})"
        if a.distance is not None and (b.distance is None or b.distance > a.distance):
            other = "no pose" if b.distance is None else f"{b.distance:.3f} m"
            return f"distance to {self.robot} ({a.id} {a.distance:.3f} m, {b.id} {other})"
        if self.robot is None:
            why = "no robot given to measure distance"
        elif self.origin is None:
            why = f"{self.robot} has no pose"
        elif a.distance is None:
            why = "neither has a pose"
        else:
            why = "equally far from the robot"
        return f"natural id order (tied on pre-conditions; {why})"


def infer(
    desc: SkillDescription,
    view: WorldView,
    values: Mapping[str, Value],
    pending: Sequence[ParamSpec],
    *,
    robot: str | None = None,
    registry: ConditionRegistry | None = None,
) -> tuple[dict[str, str], dict[str, str]]:
    """Values and reasons for the ``pending`` element parameters, given the other ``values``."""
    domains = {spec.name: domain(view, spec, desc.name) for spec in pending}
    position = {spec.name: i for i, spec in enumerate(pending)}
    order = sorted(pending, key=lambda s: (len(domains[s.name]), position[s.name]))
    search = _Search(desc, view, robot, registry)
    found = search.solve(order, domains, values)
    if isinstance(found, _DeadEnd):
        spec = next(s for s in pending if s.name == found.param)
        raise InferenceError(
            f"cannot infer parameter '{spec.name}' ({with_article(spec.type)}) of skill "
            f"'{desc.name}': {found.why}. Give '{spec.name}' explicitly"
        )
    return found, search.reasons
