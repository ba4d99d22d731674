"""Which skills of which agents become planning actions, with which variables and atoms.

:func:`draft` reads one skill of one agent: its conditions' atoms
(:func:`skill_agent.conditions.symbolic`), its hardware parameters bound to the agent's own
machine, its element parameters that become the action's variables, and what stays run-time
only; or why the planner cannot use the skill. :func:`action_names` names the actions
(``pick__robot1``). The rules are under **Actions** in :mod:`task_agent.domain`.
"""

from __future__ import annotations

import re
from collections.abc import Sequence
from typing import NamedTuple

from skill_agent import WorldView
from skill_agent.conditions import Atom, ConditionRegistry, describe, symbolic
from skill_agent.parameters import bindings
from skill_agent.protocol import Condition, SkillDescription

from ..discovery import AgentInfo

__all__ = ["Draft", "action_names", "draft", "element_is"]


class Draft(NamedTuple):
    """A skill of an agent with its atoms, before predicates are known."""

    agent: AgentInfo
    desc: SkillDescription
    variables: dict[str, str]
    """Parameter name -> ontology class (the action's variables)."""
    bound: dict[str, str]
    owned: tuple[str, ...]
    """Variables restricted to the agent's hardware (several fitting devices)."""
    pre: list[Atom]
    post: list[Atom]
    runtime_only: list[str]


def _atoms(
    conds: Sequence[Condition], registry: ConditionRegistry | None, where: str, out: list[str]
) -> list[Atom]:
    atoms: list[Atom] = []
    for cond in conds:
        found = symbolic(cond, registry=registry)
        if found is None:
            out.append(f"{where} {describe(cond)}")
        else:
            atoms += found
    return atoms


def draft(
    agent: AgentInfo, desc: SkillDescription, view: WorldView, registry: ConditionRegistry | None
) -> Draft | str:
    """The action draft of ``desc`` on ``agent``, or why the planner cannot use it."""
    onto = view.ontology
    runtime: list[str] = []
    pre = _atoms([*desc.pre, *desc.hold], registry, "pre", runtime)
    post = _atoms(desc.post, registry, "post", runtime)
    used = {a for atom in (*pre, *post) for a in atom.args}
    variables: dict[str, str] = {}
    bound: dict[str, str] = {}
    owned: list[str] = []
    pinned = bindings(desc)  # the devices the run will lock, as the agent published them
    for spec in desc.parameters:
        if spec.type not in onto.classes:
            if spec.name in used:
                return f"parameter '{spec.name}' is a {spec.type} value, not an element"
            if spec.default is None and not spec.optional and spec.kind == "online":
                return (
                    f"needs a {spec.type} value for '{spec.name}', which the planner cannot choose"
                )
            continue
        if spec.kind == "hardware" and spec.name in pinned:  # the agent's configuration's
            bound[spec.name] = pinned[spec.name]
        elif spec.kind == "hardware":
            mine = [h for h in agent.hardware if element_is(view, h, spec.type)]
            if not mine and spec.optional and spec.name not in used:
                continue
            if not mine:
                return (
                    f"agent '{agent.name}' has no {spec.type} for hardware parameter '{spec.name}'"
                )
            if len(mine) == 1:
                bound[spec.name] = mine[0]
            elif spec.name in used:
                variables[spec.name] = spec.type
                owned.append(spec.name)
        elif spec.name in used:
            variables[spec.name] = spec.type
    known = set(variables) | set(bound)
    keep_pre = [a for a in pre if set(a.args) <= known]
    keep_post = [a for a in post if set(a.args) <= known]
    for atom in (a for a in (*pre, *post) if not set(a.args) <= known):
        runtime.append(f"{atom.predicate}{atom.args} (names a non-element parameter)")
    if not keep_post:
        return "no symbolic post-condition: the planner cannot use it"
    return Draft(agent, desc, variables, bound, tuple(owned), keep_pre, keep_post, runtime)


def element_is(view: WorldView, element_id: str, cls: str) -> bool:
    """The element exists and is a ``cls`` (or a subclass)."""
    element = view.find_element(element_id)
    return element is not None and view.ontology.is_a(element.type, cls)


def action_names(drafts: Sequence[Draft]) -> list[str]:
    """A unique, PDDL-safe action name per draft: ``<skill>__<agent>``."""
    taken: set[str] = set()
    out = []
    for d in drafts:
        base = re.sub(r"[^A-Za-z0-9_]", "_", f"{d.desc.name}__{d.agent.name}")
        base = base if base[:1].isalpha() else f"a_{base}"
        name, n = base, 1
        while name.lower() in taken:
            n += 1
            name = f"{base}_{n}"
        taken.add(name.lower())
        out.append(name)
    return out
