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

Pure and synchronous. The values of step 2 are checked in ``_values`` (literals, elements) and
``_dataflow`` (references); :class:`~._attempt.Attempt` collects what one attempt found.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from typing import ClassVar

from skill_agent import InferenceError, SkillError, WorldView
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
from skill_agent.parameters import bindings, describe_query, is_value_kind, matching, specify
from skill_agent.protocol import (
    AndCond,
    Condition,
    CustomCond,
    NotCond,
    OrCond,
    ParamSpec,
)
from wm_store import WmError
from wm_store.ontology import did_you_mean
from wm_store.protocol import Value

from ..discovery import AgentInfo
from ..protocol import Call
from ..taskfile import CallSite, parse_ref
from ._attempt import REF_FORM, Attempt, Earlier, is_of, listing
from ._dataflow import flow
from ._values import check_literal

__all__ = ["CallChecker", "broken"]


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
                raw = flow(self.earlier, site, spec, ref, view, att)
                if raw is None:
                    continue
                value = check_literal(spec, raw, view, att, f" (from step '{ref.step}')")
            else:
                value = None if raw is None else check_literal(spec, raw, view, att)
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
                hardware={**{d: d for d in agent.devices}, **bindings(desc)},
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
            return f"{what} and no default: give it, or take it from an earlier step ({REF_FORM})"
        if spec.kind == "hardware":
            fitting = [d for d in agent.hardware if is_of(view, d, spec.type)]
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
