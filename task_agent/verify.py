"""Offline verification of hand-written task structures (FRIEND II): :func:`verify` finds,
before anything runs, every reason a task file would fail for its structure, names, data flow,
types, resources or pre-conditions. Pure and synchronous; problems come in document order.

Checks (``VerifyProblem.kind``)::

    structure     an empty sequence / parallel block; an id used by several blocks
    unknown       an unknown agent, a skill the agent lacks, a skill no agent offers, a
                  parameter the skill lacks (each with the closest names)
    dataflow      a required parameter with no value when its step starts: value parameters
                  need a literal, a default or '@step.param'; element parameters left out are
                  inferred at run time, accepted when the world model holds a candidate then;
                  '@step.param' must name an earlier step in sequence order (not a parallel
                  sibling, not a later step, not itself) that has that parameter
    type          a literal of the wrong kind; an element id (or 'label:') that names no
                  element, several, one of the wrong class or outside the partial definition,
                  a device of another agent; '@step.param' between incompatible types
    resource      two calls that may run at the same time lock the same device (the agent
                  would refuse the second), or use one agent whose devices are not known
    precondition  a pre- or hold-condition false when its step starts, in the symbolic
                  simulation; no candidate satisfying the pre-conditions for an inferred
                  parameter; predicted effects that cannot be committed; parallel branches
                  changing the same fact differently

**Symbolic simulation.** From a private copy of the world model, each step in execution order
is specified like the agent does (:func:`skill_agent.params.specify`: defaults, devices,
inference), its pre- and hold-conditions evaluated, then the effects of its post-conditions
applied (:func:`wm_store.transactions.apply_transaction`), also when a condition was false (so
one mistake is reported once). Each branch of a parallel block starts from the state before
the block; then every branch's effects are applied in branch order. Steps whose agent or skill
is unknown change nothing. Sensing is not simulated (a post-condition no effect makes true,
such as ``has object.pose``, is assumed; pre-sensing that moves objects is not predicted).

:func:`check` returns a :class:`Report` with the problems and also warnings (a parallel block
with one child; a data-flow source whose class is broader than the target's; a custom
condition left to run time), notes (what each inferred parameter will be) and the predicted
steps and final world model. A task with no problems does not fail for these reasons at run
time as long as the world model evolves as predicted.
"""

from __future__ import annotations

from collections import defaultdict
from collections.abc import Iterable, Sequence
from dataclasses import dataclass, field
from typing import Literal

import msgspec

from skill_agent.conditions import describe, effects, evaluate, parameters_of
from skill_agent.errors import InferenceError, ParameterTypeError, SkillError
from skill_agent.inference import describe_query, matching
from skill_agent.params import check_kind, is_value_kind, specify
from skill_agent.protocol import (
    AndCond,
    Condition,
    CustomCond,
    NotCond,
    OrCond,
    ParamSpec,
    SkillDescription,
)
from skill_agent.skill import WorldView
from wm_store.errors import WmError
from wm_store.ontology import Ontology
from wm_store.ontology_model import did_you_mean, with_article
from wm_store.protocol import Element, Op, Query, Relation, Value
from wm_store.query import id_sort_key, match_relations, resolve
from wm_store.state import SceneState
from wm_store.transactions import apply_transaction

from .discovery_model import AgentInfo
from .protocol import Call, Parallel, TaskFile, VerifyProblem
from .protocol import Sequence as SequenceBlock
from .taskfile import (
    LABEL_PREFIX,
    BlockSite,
    CallSite,
    Ref,
    assign_ids,
    blocks,
    parse_ref,
    precedes,
    walk,
    where,
)

__all__ = ["Report", "SceneView", "StepPrediction", "check", "scene_copy", "verify"]

Kind = Literal["dataflow", "type", "resource", "precondition", "unknown", "structure"]
_RANK = {k: i for i, k in enumerate(("structure", "unknown", "dataflow", "type", "resource"))}
_SIZES = frozenset({"SizeCuboid", "SizeCylinder", "SizeSphere"})


# --------------------------------------------------------------------------- the private world


class SceneView:
    """A :class:`~skill_agent.skill.WorldView` over a private :class:`SceneState`."""

    def __init__(self, state: SceneState, ontology: Ontology) -> None:
        self.state, self._ontology = state, ontology

    @property
    def ontology(self) -> Ontology:
        return self._ontology

    def get_element(self, element_id: str) -> Element:
        element = self.state.get(element_id)
        if element is None:
            raise KeyError(element_id)
        return element

    def find_element(self, element_id: str) -> Element | None:
        return self.state.get(element_id)

    def resolve_element(self, query: Query | None = None, *, type: str = "") -> list[Element]:
        return resolve(self.state, self._ontology, query or Query(type=type))

    def query_relation(
        self, subject: str = "", predicate: str = "", obj: str = ""
    ) -> list[Relation]:
        return match_relations(self.state, self._ontology, subject, predicate, obj)


def scene_copy(view: WorldView) -> SceneState:
    """A private copy of the elements and relations ``view`` shows."""
    if isinstance(view, SceneView):
        return view.state.copy()
    state = SceneState()
    state.set_spatial_predicates(n for n, r in view.ontology.relations.items() if r.spatial)
    for element in view.resolve_element():
        state.put_element(element)
    for rel in view.query_relation():
        state.add_relation(rel)
    return state


Fact = tuple[str, ...]


def _changes(before: SceneState, after: SceneState) -> dict[Fact, object]:
    """What ``after`` changed: relations (True added, False removed), properties (new value),
    spatial parents (new parent and predicate, or None)."""
    out: dict[Fact, object] = {}
    old, new = set(before.all_relations()), set(after.all_relations())
    for rel in old ^ new:
        out[("rel", rel.subject, rel.predicate, rel.object)] = rel in new
    for eid, element in after.elements.items():
        prior = before.get(eid)
        was = prior.properties if prior is not None else {}
        for name in set(was) | set(element.properties):
            if was.get(name) != element.properties.get(name):
                out[("prop", eid, name)] = element.properties.get(name)
        p0, p1 = before.parent(eid), after.parent(eid)
        if p0 != p1:
            out[("parent", eid)] = None if p1 is None else f"{p1.subject} ({p1.predicate})"
    return out


def _fact_text(fact: Fact, a: object, b: object, names: tuple[str, str]) -> str:
    if fact[0] == "parent":
        return f"where {fact[1]} ends up ({names[0]}: in {a or 'nothing'}; {names[1]}: in {b})"
    if fact[0] == "rel":
        truth = {True: "true", False: "false"}
        return (
            f"{fact[2]}({fact[1]}, {fact[3]}) ({names[0]} makes it {truth[bool(a)]}, "
            f"{names[1]} {truth[bool(b)]})"
        )
    return f"{fact[1]}.{fact[2]} ({names[0]} sets {a!r}, {names[1]} {b!r})"


# --------------------------------------------------------------------------- results


class StepPrediction(msgspec.Struct, frozen=True, kw_only=True):
    """How one call is predicted to run: agent, every parameter (inferred ones included, with
    the reasons), the effects it commits and the devices it locks."""

    path: str
    agent: str
    skill: str
    params: dict[str, Value]
    inferred: dict[str, str] = {}
    effects: list[Op] = []
    locks: list[str] = []


@dataclass
class Report:
    """Everything :func:`check` found. ``ok`` when there is no problem (warnings and notes
    do not fail a task)."""

    problems: list[VerifyProblem]
    warnings: list[VerifyProblem]
    notes: list[VerifyProblem]
    steps: list[StepPrediction]
    final: SceneView
    """The predicted world model after the last step (a private copy)."""

    @property
    def ok(self) -> bool:
        return not self.problems


# --------------------------------------------------------------------------- one call


@dataclass
class _Attempt:
    """One call on one agent, at its start in the simulation."""

    agent: AgentInfo
    desc: SkillDescription
    problems: list[tuple[Kind, str]] = field(default_factory=list)
    warnings: list[tuple[Kind, str]] = field(default_factory=list)
    given: dict[str, Value] = field(default_factory=dict)
    values: dict[str, Value] | None = None
    inferred: dict[str, str] = field(default_factory=dict)
    blocked: bool = False
    """A data-flow source has no prediction (its own problem is reported there)."""


def _custom(cond: Condition) -> bool:
    match cond:
        case CustomCond():
            return True
        case AndCond(items=items) | OrCond(items=items):
            return any(_custom(i) for i in items)
        case NotCond(item=item):
            return _custom(item)
    return False


def _names(items: Iterable[str], limit: int = 8) -> str:
    shown = list(items)
    return (
        ", ".join(shown[:limit]) + (f" and {len(shown) - limit} more" if len(shown) > limit else "")
        or "none"
    )


class _Verifier:
    def __init__(self, task: TaskFile, view: WorldView, agents: Sequence[AgentInfo]) -> None:
        self.task = assign_ids(task)
        self.ontology = view.ontology
        self.state = scene_copy(view)
        self.agents = {a.name: a for a in sorted(agents, key=lambda a: a.name)}
        self.sites = {s.path: s for s in blocks(self.task)}
        self.calls = {s.path: s for s in walk(self.task)}
        self.ids: dict[str, list[BlockSite]] = defaultdict(list)
        for site in self.sites.values():
            self.ids[site.block.id].append(site)
        self.found: list[tuple[int, int, int, str, VerifyProblem]] = []
        self.steps: dict[str, StepPrediction] = {}
        self.descs: dict[str, SkillDescription] = {}
        self.locks: dict[str, set[str]] = {}

    # ------------------------------------------------------------------ reporting

    def report(self, path: str, kind: Kind, message: str, level: str = "error") -> None:
        site = self.sites[path]
        problem = VerifyProblem(path=where(path, site.block), kind=kind, message=message)
        rank = _RANK.get(kind, len(_RANK))
        self.found.append((site.order, rank, len(self.found), level, problem))

    def result(self) -> Report:
        ordered = sorted(self.found, key=lambda f: f[:3])
        by_level: dict[str, list[VerifyProblem]] = defaultdict(list)
        for *_, level, problem in ordered:
            by_level[level].append(problem)
        steps = [self.steps[p] for p in self.calls if p in self.steps]
        view = SceneView(self.state, self.ontology)
        return Report(by_level["error"], by_level["warning"], by_level["note"], steps, view)

    # ------------------------------------------------------------------ structure

    def structure(self) -> None:
        for site in self.sites.values():
            block = site.block
            if isinstance(block, Call):
                if not block.skill:
                    self.report(site.path, "structure", "a call needs a 'skill'")
                continue
            kind = "parallel" if isinstance(block, Parallel) else "sequence"
            if not block.children:
                self.report(site.path, "structure", f"an empty {kind} block: add calls or drop it")
            elif kind == "parallel" and len(block.children) == 1:
                self.report(
                    site.path,
                    "structure",
                    "a parallel block with one child runs like a sequence; drop the block or "
                    "add the calls meant to run at the same time",
                    "warning",
                )
        for bid, sites in self.ids.items():
            for site in sites[1:]:
                self.report(
                    site.path,
                    "structure",
                    f"id '{bid}' is also used by {where(sites[0].path, sites[0].block)}; ids "
                    "must be unique ('@<step id>.<param>' names a step by its id)",
                )

    # ------------------------------------------------------------------ agents and skills

    def candidates(self, call: Call) -> list[AgentInfo] | str:
        """The agents that may run ``call`` (name order), or why there is none."""
        names = list(self.agents)
        if call.agent:
            agent = self.agents.get(call.agent)
            if agent is None:
                return f"no agent '{call.agent}'{did_you_mean(call.agent, names)} Agents: {_names(names)}"
            if not agent.available:
                return f"agent '{call.agent}' is registered but not available"
            if agent.skill(call.skill) is None:
                skills = [s.name for s in agent.skills]
                return (
                    f"agent {agent.name} has no skill '{call.skill}'"
                    f"{did_you_mean(call.skill, skills)} Its skills: {_names(skills)}"
                )
            return [agent]
        offering = [a for a in self.agents.values() if a.available and a.skill(call.skill)]
        if not offering:
            skills = sorted({s.name for a in self.agents.values() if a.available for s in a.skills})
            return (
                f"no agent offers skill '{call.skill}'{did_you_mean(call.skill, skills)} "
                f"Skills offered: {_names(skills, 20)}"
            )
        return offering

    # ------------------------------------------------------------------ parameter values

    def element_problem(
        self, spec: ParamSpec, element_id: str, view: SceneView, agent: AgentInfo
    ) -> str | None:
        onto = self.ontology
        element = view.find_element(element_id)
        if element is None:
            known = [e.id for e in view.resolve_element(type=spec.type)]
            return (
                f"no element '{element_id}' in the world model{did_you_mean(element_id, known)} "
                f"Elements of class {spec.type}: {_names(known)}"
            )
        if not onto.is_a(element.type, spec.type):
            chain = " < ".join(onto.superclasses(element.type))
            return f"takes {with_article(spec.type)}; {element_id} is {with_article(element.type)} ({chain})"
        if spec.partial is not None and element_id not in matching(view, spec):
            return f"{element_id} does not match its partial definition ({describe_query(spec.partial)})"
        if spec.kind == "hardware" and agent.robot and element_id not in agent.hardware:
            mine = [d for d in agent.hardware if _is(view, d, spec.type)]
            return (
                f"{element_id} is not a device of agent {agent.name}; its {spec.type} devices: "
                f"{_names(mine)}"
            )
        return None

    def literal(
        self, spec: ParamSpec, raw: Value, view: SceneView, att: _Attempt, origin: str = ""
    ) -> Value:
        head = f"parameter '{spec.name}'{origin}"
        if is_value_kind(spec.type):
            try:
                return check_kind(spec, raw)
            except ParameterTypeError as exc:
                att.problems.append(("type", f"{exc}{origin}"))
                return None
        if not isinstance(raw, str):
            want = with_article(spec.type)
            att.problems.append(
                ("type", f"{head} takes an element id or 'label:<label>' ({want}), got {raw!r}")
            )
            return None
        element_id = raw
        if raw.startswith(LABEL_PREFIX):
            label = raw[len(LABEL_PREFIX) :]
            found = [e.id for e in view.resolve_element(Query(label=label))]
            if len(found) != 1:
                labels = {e.label for e in view.resolve_element(type=spec.type) if e.label}
                why = (
                    f"is ambiguous: {_names(found)}; write an id instead"
                    if found
                    else f"names no element{did_you_mean(label, labels)}"
                )
                att.problems.append(("type", f"{head}: the label '{label}' {why}"))
                return None
            element_id = found[0]
        problem = self.element_problem(spec, element_id, view, att.agent)
        if problem is not None:
            att.problems.append(
                (
                    "type",
                    f"{head} {problem}" if problem.startswith("takes") else f"{head}: {problem}",
                )
            )
            return None
        return element_id

    def compatible(self, src: ParamSpec, dst: ParamSpec, text: str, att: _Attempt) -> bool:
        """Whether ``src``'s values can fit ``dst`` (a narrower element class: a warning)."""
        s_value, d_value = is_value_kind(src.type), is_value_kind(dst.type)
        if s_value and d_value:
            same = {src.type, dst.type} <= {"str", "string"} or src.type == dst.type
            fits = same or dst.type == "any" or (src.type, dst.type) == ("int", "float")
            fits = fits or (dst.type == "Size" and src.type in _SIZES)
        elif not s_value and not d_value:
            if self.ontology.is_a(src.type, dst.type):
                return True
            fits = self.ontology.is_a(dst.type, src.type)
            if fits:
                att.warnings.append(
                    (
                        "type",
                        f"{text}: the source is any {src.type}, '{dst.name}' takes "
                        f"{with_article(dst.type)} only; the predicted value is checked, "
                        "the value at run time may differ",
                    )
                )
        else:
            fits = False
        if not fits:
            att.problems.append(
                (
                    "type",
                    f"{text}: the source is {with_article(src.type)}, "
                    f"'{dst.name}' takes {with_article(dst.type)}",
                )
            )
        return fits

    def flow(
        self, site: CallSite, spec: ParamSpec, ref: Ref, view: SceneView, att: _Attempt
    ) -> Value:
        text = f"parameter '{spec.name}' = '@{ref.step}.{ref.param}'" if ref.param else ""
        if not ref.param:
            att.problems.append(
                (
                    "dataflow",
                    f"parameter '{spec.name}': '@{ref.step}' is not a "
                    "reference; write '@<step id>.<param>'",
                )
            )
            return None
        sources = self.ids.get(ref.step, [])
        src = sources[0] if sources else None
        why = ""
        if src is None:
            ids = [s.block.id for s in self.calls.values()]
            why = f"there is no step '{ref.step}'{did_you_mean(ref.step, ids)}"
        elif not isinstance(src.block, Call):
            why = f"'{ref.step}' is a {type(src.block).__name__.lower()} block, not a call"
        elif src.path == site.path:
            why = "a step cannot take a value from itself"
        elif src.path in site.parallel:
            why = (
                f"step '{ref.step}' may run at the same time as this one (a parallel branch), "
                "so its values are not known when this step starts; order it before this "
                "step in a sequence"
            )
        elif not precedes(self.calls[src.path], site):
            why = f"step '{ref.step}' runs after this one; only earlier steps' values are known"
        if why or src is None:
            att.problems.append(("dataflow", f"{text}: {why}"))
            return None
        desc = self.descs.get(src.path)
        if desc is None:
            att.blocked = True
            return None
        source = next((p for p in desc.parameters if p.name == ref.param), None)
        if source is None:
            names = [p.name for p in desc.parameters]
            att.problems.append(
                (
                    "dataflow",
                    f"{text}: step '{ref.step}' (skill {desc.name}) has no "
                    f"parameter '{ref.param}'{did_you_mean(ref.param, names)}",
                )
            )
            return None
        if not self.compatible(source, spec, text, att):
            return None
        prediction = self.steps.get(src.path)
        if prediction is None:
            att.blocked = True
            return None
        value = prediction.params.get(ref.param)
        if value is None:
            att.problems.append(
                (
                    "dataflow",
                    f"{text}: step '{ref.step}' runs without "
                    f"'{ref.param}' (optional, not given), so nothing flows",
                )
            )
            return None
        return self.literal(spec, value, view, att, f" (from step '{ref.step}')")

    # ------------------------------------------------------------------ one attempt

    def missing(self, spec: ParamSpec, agent: AgentInfo, view: SceneView) -> str | None:
        """Why ``spec``, given no value, cannot be specified when the step starts (or None)."""
        if spec.default is not None or spec.optional:
            return None
        what = f"parameter '{spec.name}' ({spec.type}) has no value"
        if is_value_kind(spec.type):
            return f"{what} and no default: give it, or take it from an earlier step with '@<step id>.<param>'"
        if spec.kind == "hardware":
            fitting = [d for d in agent.hardware if _is(view, d, spec.type)]
            if spec.partial is not None:
                fitting = [d for d in fitting if d in set(matching(view, spec))]
            if not fitting:
                return (
                    f"{what} and agent {agent.name} has no such device to bind (its devices: "
                    f"{_names(agent.hardware)}); give it"
                )
            return None
        if not matching(view, spec):
            partial = "" if spec.partial is None else f" matching {describe_query(spec.partial)}"
            return (
                f"{what} and cannot be inferred: the world model holds no {spec.type}{partial} "
                "when this step starts; give it"
            )
        return None

    def attempt(self, site: CallSite, agent: AgentInfo, view: SceneView) -> _Attempt:
        desc = agent.skill(site.call.skill)
        assert desc is not None  # candidates() offers only agents with the skill
        att = _Attempt(agent, desc)
        names = [p.name for p in desc.parameters]
        for name in site.call.params:
            if name not in names:
                att.problems.append(
                    (
                        "unknown",
                        f"skill {desc.name} has no parameter '{name}'"
                        f"{did_you_mean(name, names)} Its parameters: {_names(names, 20)}",
                    )
                )
        for spec in desc.parameters:
            raw = site.call.params.get(spec.name)
            if raw is None:
                continue
            ref = parse_ref(raw)
            value = (
                self.flow(site, spec, ref, view, att) if ref else self.literal(spec, raw, view, att)
            )
            if value is not None:
                att.given[spec.name] = value
        if att.problems or att.blocked:
            return att
        for spec in desc.parameters:
            why = None if spec.name in att.given else self.missing(spec, agent, view)
            if why:
                att.problems.append(("dataflow", why))
        if att.problems:
            return att
        hardware = {d: d for d in agent.devices}
        try:
            specified = specify(desc, att.given, view, hardware=hardware, robot=agent.robot)
        except InferenceError as exc:
            att.problems.append(("precondition", str(exc)))
            return att
        except (SkillError, WmError) as exc:
            att.problems.append(("type", str(exc)))
            return att
        att.values, att.inferred = specified.values, specified.inferred
        self.conditions(att, view)
        return att

    def conditions(self, att: _Attempt, view: SceneView) -> None:
        assert att.values is not None
        hold = [c for c in att.desc.hold if c not in att.desc.pre]
        for section, conds in (("pre-condition", att.desc.pre), ("hold-condition", hold)):
            for cond in conds:
                if _custom(cond):
                    att.warnings.append(
                        (
                            "precondition",
                            f"{section} {describe(cond)} uses a "
                            "custom condition: checked only when the step runs",
                        )
                    )
                    continue
                verdict = evaluate(cond, view, att.values)
                if not verdict.ok:
                    bound = ", ".join(
                        f"{p}={att.values.get(p)}" for p in sorted(parameters_of(cond))
                    )
                    att.problems.append(
                        (
                            "precondition",
                            f"{section} {describe(cond)} [{bound}] does "
                            f"not hold when the step starts: {verdict.reason}",
                        )
                    )

    # ------------------------------------------------------------------ simulation

    def step(self, site: CallSite, state: SceneState, journal: list[list[Op]]) -> None:
        found = self.candidates(site.call)
        if isinstance(found, str):
            self.report(site.path, "unknown", found)
            return
        view = SceneView(state, self.ontology)
        attempts: list[_Attempt] = []
        for agent in found:
            attempts.append(self.attempt(site, agent, view))
            if not attempts[-1].problems:
                break
        att = attempts[-1] if not attempts[-1].problems else attempts[0]
        self.descs[site.path] = att.desc
        head = f"{att.desc.name} on {att.agent.name}: "
        if att.problems and len(found) > 1:
            head = f"no agent offering {att.desc.name} can run it; on {att.agent.name}: "
        for level, items in (("error", att.problems), ("warning", att.warnings)):
            for kind, message in items:
                self.report(site.path, kind, head + message, level)
        fixed = len(found) == 1
        self.locks[site.path] = self.lock_set(att, fixed)
        if att.values is None:
            return
        for name, reason in att.inferred.items():
            self.report(site.path, "dataflow", f"{head}'{name}' will be inferred: {reason}", "note")
        try:
            ops = effects(att.desc.post, view, att.values)
            apply_transaction(state, self.ontology, ops, revision=state.revision + 1, now=0.0)
        except (SkillError, WmError) as exc:
            self.report(
                site.path, "precondition", f"{head}its predicted effects cannot be committed: {exc}"
            )
            ops = []
        state.revision += 1
        journal.append(ops)
        self.steps[site.path] = StepPrediction(
            path=site.path,
            agent=att.agent.name,
            skill=att.desc.name,
            params=att.values,
            inferred=att.inferred,
            effects=ops,
            locks=sorted(self.locks[site.path], key=id_sort_key),
        )

    def lock_set(self, att: _Attempt, fixed: bool) -> set[str]:
        """The devices the call locks: given ones always; inferred ones when the agent is
        fixed; the agent itself when its devices for the call cannot be known."""
        hardware = [p for p in att.desc.parameters if p.kind == "hardware"]
        values = att.values if att.values is not None else att.given
        locks = {v for p in hardware if isinstance(v := values.get(p.name), str)}
        if not fixed:
            locks = {v for p in hardware if isinstance(v := att.given.get(p.name), str)}
        elif att.values is None and any(
            p.name not in att.given and not p.optional for p in hardware
        ):
            locks.add(f"agent:{att.agent.name}")
        return locks

    def run(self, site: BlockSite, state: SceneState, journal: list[list[Op]]) -> None:
        block = site.block
        if isinstance(block, Call):
            self.step(self.calls[site.path], state, journal)
            return
        children = [self.sites[f"{site.path}.{i}"] for i in range(len(block.children))]
        if isinstance(block, SequenceBlock):
            for child in children:
                self.run(child, state, journal)
            return
        branches: list[tuple[BlockSite, SceneState, list[list[Op]]]] = []
        for child in children:
            branch, ops = state.copy(), []
            branch.revision = state.revision
            self.run(child, branch, ops)
            branches.append((child, branch, ops))
        clashing = self.conflicts(site, state, branches)
        for i, (child, _, ops_list) in enumerate(branches):
            for ops in ops_list:
                try:
                    apply_transaction(
                        state, self.ontology, ops, revision=state.revision + 1, now=0.0
                    )
                except WmError as exc:
                    if i not in clashing:
                        self.report(
                            site.path,
                            "precondition",
                            f"the effects of branch "
                            f"{where(child.path, child.block)} cannot be combined with "
                            f"the other branches': {exc}",
                        )
                state.revision += 1
                journal.append(ops)

    def conflicts(
        self,
        site: BlockSite,
        before: SceneState,
        branches: list[tuple[BlockSite, SceneState, list[list[Op]]]],
    ) -> set[int]:
        changes = [_changes(before, branch) for _, branch, _ in branches]
        clashing: set[int] = set()
        for i in range(len(branches)):
            for j in range(i + 1, len(branches)):
                names = (
                    where(branches[i][0].path, branches[i][0].block),
                    where(branches[j][0].path, branches[j][0].block),
                )
                for fact in sorted(changes[i].keys() & changes[j].keys()):
                    a, b = changes[i][fact], changes[j][fact]
                    if a != b:
                        clashing |= {i, j}
                        self.report(
                            site.path,
                            "precondition",
                            f"branches {names[0]} and {names[1]} "
                            f"may run at the same time and both change {_fact_text(fact, a, b, names)}; "
                            "the outcome depends on timing: order them in a sequence",
                        )
        return clashing

    # ------------------------------------------------------------------ resources

    def resources(self) -> None:
        for site in self.calls.values():
            mine = self.locks.get(site.path, set())
            clashes = []
            for other in site.parallel:
                common = mine & self.locks.get(other, set())
                if common and self.calls[other].order < site.order:
                    what = ", ".join(self.device_text(d) for d in sorted(common, key=id_sort_key))
                    clashes.append(f"{where(other, self.calls[other].call)} (both lock {what})")
            if clashes:
                self.report(
                    site.path,
                    "resource",
                    f"may run at the same time as {'; '.join(clashes)}: "
                    "an agent runs one skill per device at a time and refuses the second "
                    "start; order them in a sequence or use other devices",
                )

    def device_text(self, lock: str) -> str:
        if lock.startswith("agent:"):
            return f"agent {lock[6:]} (its devices for these calls are not known)"
        element = self.state.get(lock)
        return (
            f"{lock} ({element.label})"
            if element is not None and element.label and element.label != lock
            else lock
        )


def _is(view: WorldView, element_id: str, cls: str) -> bool:
    element = view.find_element(element_id)
    return element is not None and view.ontology.is_a(element.type, cls)


# --------------------------------------------------------------------------- entry points


def check(task: TaskFile, view: WorldView, agents: Sequence[AgentInfo]) -> Report:
    """Verify ``task`` against the world model ``view`` (not changed: the simulation runs on
    a private copy) and the discovered ``agents``; see the module doc."""
    verifier = _Verifier(task, view, agents)
    verifier.structure()
    verifier.run(verifier.sites["root"], verifier.state, [])
    verifier.resources()
    return verifier.result()


def verify(task: TaskFile, view: WorldView, agents: Sequence[AgentInfo]) -> list[VerifyProblem]:
    """Every problem of ``task`` (empty: it verifies), in document order; see :func:`check`."""
    return check(task, view, agents).problems
