"""One call of a task file when its step starts in the symbolic simulation of
:mod:`task_agent.verification`.

:meth:`CallChecker.candidates` finds the agents that may run the call (the named one, or every
available agent offering the skill), or says why none can. :meth:`CallChecker.attempt` tries
the call on one agent against the simulated world model, the way the agent itself would start
it:

1. parameter names exist in the skill's description (``unknown``);
2. each given value is checked: a literal's kind or element (id or ``label:<label>``: it
   exists, once, of the parameter's class, within its partial definition, a device of this
   agent for a hardware parameter) (``type``); ``@<step id>.<param>`` names an earlier step in
   sequence order that has that parameter (``dataflow``), of a compatible type (``type``),
   and the value that step is predicted to run with is checked like a literal;
3. every parameter left out can be specified: a value parameter needs a default, a hardware
   parameter a device of the agent, an element parameter a candidate in the world model
   (``dataflow``); then :func:`skill_agent.parameters.specify` binds them (no candidate satisfying
   the pre-conditions: ``precondition``);
4. pre-conditions, and hold-conditions not among them, hold (``precondition``); custom
   conditions are left to run time with a warning.

Pure and synchronous.
"""

from __future__ import annotations

from collections.abc import Iterable, Mapping, Sequence
from dataclasses import dataclass, field
from typing import ClassVar, Literal

from skill_agent import InferenceError, ParameterTypeError, SkillError, WorldView
from skill_agent.conditions import (
    Atom,
    Bindings,
    ConditionRegistry,
    CustomCondition,
    Verdict,
    describe,
    evaluate,
    parameters_of,
)
from skill_agent.parameters import check_kind, describe_query, is_value_kind, matching, specify
from skill_agent.protocol import (
    AndCond,
    Condition,
    CustomCond,
    NotCond,
    OrCond,
    ParamSpec,
    SkillDescription,
)
from wm_store import WmError
from wm_store.ontology import did_you_mean, with_article
from wm_store.protocol import Query, Value

from ..discovery import AgentInfo
from ..protocol import Call
from ..taskfile import LABEL_PREFIX, BlockSite, CallSite, Ref, parse_ref, precedes

__all__ = ["Attempt", "CallChecker", "Earlier", "Kind", "broken", "listing"]

Kind = Literal["dataflow", "type", "resource", "precondition", "unknown", "structure"]
_SIZES = frozenset({"SizeCuboid", "SizeCylinder", "SizeSphere"})
_REF_FORM = "'@<step id>.<param>'"


def listing(items: Iterable[str], limit: int = 8) -> str:
    """``a, b, c and 4 more`` (``none`` when empty)."""
    shown = list(items)
    more = f" and {len(shown) - limit} more" if len(shown) > limit else ""
    return ", ".join(shown[:limit]) + more if shown else "none"


@dataclass
class Attempt:
    """One call on one agent: what was found, and the values it would run with."""

    agent: AgentInfo
    desc: SkillDescription
    problems: list[tuple[Kind, str]] = field(default_factory=list)
    warnings: list[tuple[Kind, str]] = field(default_factory=list)
    given: dict[str, Value] = field(default_factory=dict)
    """The values the call gives (labels and references resolved)."""
    values: dict[str, Value] | None = None
    """Every parameter as specified (None: the call cannot be specified)."""
    inferred: dict[str, str] = field(default_factory=dict)
    blocked: bool = False
    """A data-flow source has no prediction (its own problem is reported there)."""

    def fail(self, kind: Kind, message: str) -> None:
        self.problems.append((kind, message))


@dataclass(frozen=True)
class Earlier:
    """What the steps simulated so far left for data flow (all keyed by block path)."""

    ids: Mapping[str, Sequence[BlockSite]]
    """Block id -> the blocks with that id (several: a structure problem)."""
    calls: Mapping[str, CallSite]
    descs: Mapping[str, SkillDescription]
    """The description of each call whose agent and skill are known."""
    params: Mapping[str, Mapping[str, Value]]
    """The predicted values of each call that could be specified."""


class _Assumed:
    """A custom condition the verifier cannot evaluate (the agent's registry is not here):
    assumed to hold, so inference ranks candidates on the other conditions."""

    name: ClassVar[str] = "assumed"

    def evaluate(
        self, view: WorldView, bindings: Bindings, params: Sequence[str], args: Mapping[str, Value]
    ) -> Verdict:
        return Verdict(True, "a custom condition, assumed here (checked at run time)")

    def symbolic(self, params: Sequence[str], args: Mapping[str, Value]) -> list[Atom] | None:
        return None


class _AssumeCustom(ConditionRegistry):
    def get(self, name: str) -> CustomCondition:
        return _Assumed()


def _custom(cond: Condition) -> bool:
    match cond:
        case CustomCond():
            return True
        case AndCond(items=items) | OrCond(items=items):
            return any(_custom(i) for i in items)
        case NotCond(item=item):
            return _custom(item)
    return False


def _is(view: WorldView, element_id: str, cls: str) -> bool:
    element = view.find_element(element_id)
    return element is not None and view.ontology.is_a(element.type, cls)


def broken(att: Attempt, view: WorldView) -> list[tuple[str, Condition, str]]:
    """The pre-conditions and hold-conditions (custom ones left out) of a specified attempt
    that are false in ``view``: ``("pre-condition contain(gripper, object) [gripper=...]",
    the condition, the reason)``."""
    assert att.values is not None
    values = att.values
    hold = [c for c in att.desc.hold if c not in att.desc.pre]
    out = []
    for section, conds in (("pre-condition", att.desc.pre), ("hold-condition", hold)):
        for cond in conds:
            if _custom(cond):
                continue
            verdict = evaluate(cond, view, values)
            if not verdict.ok:
                bound = ", ".join(f"{p}={values.get(p)}" for p in sorted(parameters_of(cond)))
                out.append((f"{section} {describe(cond)} [{bound}]", cond, verdict.reason))
    return out


class CallChecker:
    def __init__(self, agents: Sequence[AgentInfo], earlier: Earlier) -> None:
        self.agents = {a.name: a for a in sorted(agents, key=lambda a: a.name)}
        self.earlier = earlier

    # ------------------------------------------------------------------ agents

    def candidates(self, call: Call) -> list[AgentInfo] | str:
        """The agents that may run ``call`` (by name), or why there is none."""
        names = list(self.agents)
        if call.agent:
            agent = self.agents.get(call.agent)
            if agent is None:
                hint = did_you_mean(call.agent, names)
                return f"no agent '{call.agent}'{hint} Agents: {listing(names)}"
            if not agent.available:
                return f"agent '{call.agent}' is registered but not available"
            if agent.skill(call.skill) is None:
                skills = [s.name for s in agent.skills]
                hint = did_you_mean(call.skill, skills)
                have = f"Its skills: {listing(skills)}"
                return f"agent {agent.name} has no skill '{call.skill}'{hint} {have}"
            return [agent]
        offering = [a for a in self.agents.values() if a.available and a.skill(call.skill)]
        if offering:
            return offering
        skills = sorted({s.name for a in self.agents.values() if a.available for s in a.skills})
        hint = did_you_mean(call.skill, skills)
        return f"no agent offers skill '{call.skill}'{hint} Skills offered: {listing(skills, 20)}"

    # ------------------------------------------------------------------ one attempt

    def attempt(self, site: CallSite, agent: AgentInfo, view: WorldView) -> Attempt:
        """``site``'s call on ``agent`` (which offers the skill), in ``view`` (see module doc)."""
        desc = agent.skill(site.call.skill)
        assert desc is not None  # candidates() offers only agents with the skill
        att = Attempt(agent, desc)
        names = [p.name for p in desc.parameters]
        for name in site.call.params:
            if name not in names:
                hint = did_you_mean(name, names)
                att.fail(
                    "unknown",
                    f"skill {desc.name} has no parameter '{name}'{hint} "
                    f"Its parameters: {listing(names, 20)}",
                )
        for spec in desc.parameters:
            raw = site.call.params.get(spec.name)
            ref = parse_ref(raw)
            if ref is not None:
                raw = self._flow(site, spec, ref, view, att)
                if raw is None:
                    continue
                value = self._literal(spec, raw, view, att, f" (from step '{ref.step}')")
            else:
                value = None if raw is None else self._literal(spec, raw, view, att)
            if value is not None:
                att.given[spec.name] = value
        if att.problems or att.blocked:
            return att
        for spec in desc.parameters:
            why = None if spec.name in att.given else self._missing(spec, agent, view)
            if why:
                att.fail("dataflow", why)
        if att.problems:
            return att
        try:
            specified = specify(
                desc,
                att.given,
                view,
                hardware={d: d for d in agent.devices},
                robot=agent.robot,
                registry=_AssumeCustom(),
            )
        except InferenceError as exc:
            att.fail("precondition", str(exc))
            return att
        except (SkillError, WmError) as exc:  # pragma: no cover - the checks above come first
            att.fail("type", str(exc))
            return att
        att.values, att.inferred = specified.values, specified.inferred
        self._conditions(att, view)
        return att

    def _conditions(self, att: Attempt, view: WorldView) -> None:
        assert att.values is not None
        for cond in [*att.desc.pre, *att.desc.hold]:
            if _custom(cond):
                message = f"{describe(cond)} is a custom condition: checked only when the step runs"
                att.warnings.append(("precondition", message))
        for text, _, reason in broken(att, view):
            att.fail("precondition", f"{text} does not hold when the step starts: {reason}")

    def _missing(self, spec: ParamSpec, agent: AgentInfo, view: WorldView) -> str | None:
        """Why ``spec``, given no value, cannot be specified when the step starts (or None)."""
        if spec.default is not None or spec.optional:
            return None
        what = f"parameter '{spec.name}' ({spec.type}) has no value"
        if is_value_kind(spec.type):
            return f"{what} and no default: give it, or take it from an earlier step ({_REF_FORM})"
        if spec.kind == "hardware":
            fitting = [d for d in agent.hardware if _is(view, d, spec.type)]
            if spec.partial is not None:
                fitting = [d for d in fitting if d in set(matching(view, spec))]
            if fitting:
                return None
            return (
                f"{what} and agent {agent.name} has no such device to bind (its devices: "
                f"{listing(agent.hardware)}); give it"
            )
        if matching(view, spec):
            return None  # inferred when the step starts
        partial = "" if spec.partial is None else f" matching {describe_query(spec.partial)}"
        return (
            f"{what} and cannot be inferred: the world model holds no {spec.type}{partial} "
            "when this step starts; give it"
        )

    # ------------------------------------------------------------------ values

    def _literal(
        self, spec: ParamSpec, raw: Value, view: WorldView, att: Attempt, origin: str = ""
    ) -> Value:
        """``raw`` checked for ``spec`` (a label resolved), or None after a problem."""
        head = f"parameter '{spec.name}'{origin}"
        if is_value_kind(spec.type):
            try:
                return check_kind(spec, raw)
            except ParameterTypeError as exc:
                att.fail("type", f"{exc}{origin}")
                return None
        if not isinstance(raw, str):
            att.fail(
                "type",
                f"{head} takes an element id or 'label:<label>' "
                f"({with_article(spec.type)}), got {raw!r}",
            )
            return None
        element_id = raw
        if raw.startswith(LABEL_PREFIX):
            label = raw[len(LABEL_PREFIX) :]
            found = [e.id for e in view.resolve_element(Query(label=label))]
            if len(found) != 1:
                labels = {e.label for e in view.resolve_element(type=spec.type) if e.label}
                why = (
                    f"is ambiguous: {listing(found)}; write an id instead"
                    if found
                    else (f"names no element{did_you_mean(label, labels)}")
                )
                att.fail("type", f"{head}: the label '{label}' {why}")
                return None
            element_id = found[0]
        problem = self._element(spec, element_id, view, att.agent)
        if problem:
            att.fail("type", f"{head}{problem}")
            return None
        return element_id

    def _element(self, spec: ParamSpec, element_id: str, view: WorldView, agent: AgentInfo) -> str:
        onto = view.ontology
        element = view.find_element(element_id)
        if element is None:
            known = [e.id for e in view.resolve_element(type=spec.type)]
            hint = did_you_mean(element_id, known)
            return (
                f": no element '{element_id}' in the world model{hint} Elements of class "
                f"{spec.type}: {listing(known)}"
            )
        if not onto.is_a(element.type, spec.type):
            chain = " < ".join(onto.superclasses(element.type))
            return (
                f" takes {with_article(spec.type)}; {element_id} is "
                f"{with_article(element.type)} ({chain})"
            )
        if spec.partial is not None and element_id not in matching(view, spec):
            return f": {element_id} does not match ({describe_query(spec.partial)})"
        if spec.kind == "hardware" and agent.robot and element_id not in agent.hardware:
            mine = [d for d in agent.hardware if _is(view, d, spec.type)]
            return (
                f": {element_id} is not a device of agent {agent.name}; its {spec.type} "
                f"devices: {listing(mine)}"
            )
        return ""

    # ------------------------------------------------------------------ data flow

    def _flow(
        self, site: CallSite, spec: ParamSpec, ref: Ref, view: WorldView, att: Attempt
    ) -> Value:
        """The value ``ref`` passes to ``spec`` (unchecked), or None (problem or blocked)."""
        text = f"parameter '{spec.name}' = '@{ref.step}.{ref.param}'"
        if not ref.param:
            att.fail(
                "dataflow",
                f"parameter '{spec.name}': '@{ref.step}' is not a reference; write {_REF_FORM}",
            )
            return None
        why = self._order(site, ref)
        if why:
            att.fail("dataflow", f"{text}: {why}")
            return None
        path = self.earlier.ids[ref.step][0].path
        desc = self.earlier.descs.get(path)
        if desc is None:
            att.blocked = True
            return None
        source = next((p for p in desc.parameters if p.name == ref.param), None)
        if source is None:
            hint = did_you_mean(ref.param, [p.name for p in desc.parameters])
            att.fail(
                "dataflow",
                f"{text}: step '{ref.step}' (skill {desc.name}) has no "
                f"parameter '{ref.param}'{hint}",
            )
            return None
        if not self._compatible(source, spec, text, att, view):
            return None
        params = self.earlier.params.get(path)
        if params is None:
            att.blocked = True
            return None
        value = params.get(ref.param)
        if value is None:
            att.fail(
                "dataflow",
                f"{text}: step '{ref.step}' runs without '{ref.param}' "
                "(optional and not given), so no value flows",
            )
        return value

    def _order(self, site: CallSite, ref: Ref) -> str:
        """Why step ``ref.step`` cannot pass values to ``site`` ("" if it can)."""
        sources = self.earlier.ids.get(ref.step, ())
        if not sources:
            ids = [c.call.id for c in self.earlier.calls.values()]
            return f"there is no step '{ref.step}'{did_you_mean(ref.step, ids)}"
        src = sources[0]
        if not isinstance(src.block, Call):
            return f"'{ref.step}' is a {type(src.block).__name__.lower()} block, not a call"
        if src.path == site.path:
            return "a step cannot take a value from itself"
        if src.path in site.parallel:
            return (
                f"step '{ref.step}' may run at the same time as this one (a parallel "
                "branch), so its values are not known when this step starts; order it "
                "before this step in a sequence"
            )
        if not precedes(self.earlier.calls[src.path], site):
            return f"step '{ref.step}' runs after this one; only earlier steps' values are known"
        return ""

    def _compatible(
        self, src: ParamSpec, dst: ParamSpec, text: str, att: Attempt, view: WorldView
    ) -> bool:
        """Whether ``src``'s values can fit ``dst``; a narrower target class is a warning."""
        s_value, d_value = is_value_kind(src.type), is_value_kind(dst.type)
        if s_value and d_value:
            fits = src.type == dst.type or {src.type, dst.type} <= {"str", "string"}
            fits = fits or dst.type == "any" or (src.type, dst.type) == ("int", "float")
            fits = fits or (dst.type == "Size" and src.type in _SIZES)
        elif not s_value and not d_value:
            onto = view.ontology
            if onto.is_a(src.type, dst.type):
                return True
            fits = onto.is_a(dst.type, src.type)
            if fits:
                att.warnings.append(
                    (
                        "type",
                        f"{text}: the source is any {src.type}, "
                        f"'{dst.name}' takes {with_article(dst.type)} only; the "
                        "predicted value is checked, the one at run time may "
                        "differ",
                    )
                )
        else:
            fits = False
        if not fits:
            att.fail(
                "type",
                f"{text}: the source is {with_article(src.type)}, '{dst.name}' "
                f"takes {with_article(dst.type)}",
            )
        return fits
