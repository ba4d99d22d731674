"""A value a call gives one parameter, checked as its agent would check it: a literal's kind, or
an element (id or ``label:<label>``) that exists once, of the parameter's class, within its
partial definition, a device of the agent for a hardware parameter."""

from __future__ import annotations

from skill_agent import ParameterTypeError, WorldView
from skill_agent.parameters import check_kind, describe_query, is_value_kind, matching
from skill_agent.protocol import ParamSpec
from wm_store import display_name
from wm_store.ontology import did_you_mean, with_article
from wm_store.protocol import Query, Value

from ..discovery import AgentInfo
from ..taskfile import LABEL_PREFIX
from ._attempt import Attempt, is_of, listing

__all__ = ["check_literal"]


def check_literal(
    spec: ParamSpec, raw: Value, view: WorldView, att: Attempt, origin: str = ""
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
        labelled = view.resolve_element(Query(label=label))
        found = [e.id for e in labelled]
        if len(found) > 1:  # an agent shares its robot's label: the label means the robot
            found = [e.id for e in labelled if not _agent_or_skill(view, e.type)] or found
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
    problem = _element(spec, element_id, view, att.agent)
    if problem:
        att.fail("type", f"{head}{problem}")
        return None
    return element_id


def _agent_or_skill(view: WorldView, cls: str) -> bool:
    onto = view.ontology
    return any(c in onto.classes and onto.is_a(cls, c) for c in ("Agent", "Skill"))


def _element(spec: ParamSpec, element_id: str, view: WorldView, agent: AgentInfo) -> str:
    onto = view.ontology
    element = view.find_element(element_id)
    if element is None:
        known = [e.id for e in view.resolve_element(type=spec.type)]
        hint = did_you_mean(element_id, known)
        return (
            f": no element '{element_id}' in the world model{hint} Elements of class "
            f"{spec.type}: {listing(known)}"
        )
    name = display_name(element)
    if not onto.is_a(element.type, spec.type):
        chain = " < ".join(onto.superclasses(element.type))
        return f" takes {with_article(spec.type)}; {name} is {with_article(element.type)} ({chain})"
    if spec.partial is not None and element_id not in matching(view, spec):
        return f": {name} does not match ({describe_query(spec.partial)})"
    bound = element_id == spec.default  # the device the agent's configuration binds
    if spec.kind == "hardware" and agent.robot and not bound and element_id not in agent.hardware:
        mine = [
            display_name(view.find_element(d), d)
            for d in agent.hardware
            if is_of(view, d, spec.type)
        ]
        return (
            f": {name} is not a device of agent {agent.name}; its {spec.type} "
            f"devices: {listing(mine)}"
        )
    return ""
