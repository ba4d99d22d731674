"""What the executor runs, as data (pure: no Zenoh, nothing blocks).

- :class:`StepSpec`: one skill call with the steps that must finish first. A plan
  (:func:`steps_from_plan`) and a hand-written task file (:func:`steps_from_file`) both become
  a list of them; step numbers are unique within a task (a replan continues the numbering).
- :class:`StepGraph`: which steps may start, run, succeeded or failed.
- :func:`resolve_params`: a task file's data flow (``"@pick1.object"``: the value step
  ``pick1`` ran with, inferred ones included) and ``"label:<label>"`` element references.
- :func:`unmet_goal`: the goal literals the world model does not satisfy, with the reason.
"""

from __future__ import annotations

from collections.abc import Iterable, Mapping, Sequence
from typing import TYPE_CHECKING, Literal, Protocol

import msgspec

from skill_agent import WorldView
from skill_agent.conditions import evaluate
from skill_agent.protocol import Condition, PropertyCond, RelationCond
from wm_store.protocol import Query, Value

from .._errors import StepInputError
from .._goals import Goal, RelationGoal
from ..protocol import PlannedStep, TaskFile
from ..taskfile import LABEL_PREFIX, assign_ids, parse_ref, precedes, walk

if TYPE_CHECKING:  # planning imports unified-planning (slow): only the executor needs it
    from ..planning import PartialOrderPlan

__all__ = [
    "OPERATOR_NOTE",
    "StepGraph",
    "StepSpec",
    "StepStatus",
    "WorldModel",
    "resolve_params",
    "schedule",
    "steps_from_file",
    "steps_from_plan",
    "unmet_goal",
]

OPERATOR_NOTE = "operator_note"
"""The text parameter every skill of the operator agent takes: what to do and why."""

StepStatus = Literal["waiting", "running", "succeeded", "failed"]


class WorldModel(WorldView, Protocol):
    """The world-model client as the executor uses it: local reads, and waiting until the
    replica shows a revision (the effects of a finished step). :class:`wm_store.WmClient` is
    one."""

    async def wait_for_revision(self, revision: int, *, timeout: float | None = None) -> None: ...


class StepSpec(msgspec.Struct, frozen=True, kw_only=True):
    index: int
    """Unique within the task."""
    agent: str
    """Empty: any available agent offering ``skill`` (task files)."""
    skill: str
    params: dict[str, Value]
    after: tuple[int, ...] = ()
    call_id: str = ""
    """The task file's ``Call.id`` (data flow refers to it)."""
    fallback_operator: bool = False
    start: float = 0.0
    finish: float = 0.0

    def planned(self) -> PlannedStep:
        return PlannedStep(
            index=self.index,
            agent=self.agent,
            skill=self.skill,
            params=dict(self.params),
            after=list(self.after),
            start=self.start,
            finish=self.finish,
        )

    def __str__(self) -> str:
        return f"step {self.index} {self.skill} on {self.agent or 'any agent'}"


def steps_from_plan(plan: PartialOrderPlan, first: int = 0) -> list[StepSpec]:
    """The plan's steps, numbered from ``first``, with their predecessors."""
    return [
        StepSpec(
            index=first + i,
            agent=s.step.agent,
            skill=s.step.skill,
            params=dict(s.step.params),
            after=tuple(first + p for p in plan.predecessors(i)),
            start=s.start,
            finish=s.finish,
        )
        for i, s in enumerate(plan.steps)
    ]


def steps_from_file(task_file: TaskFile) -> list[StepSpec]:
    """The calls of a task file in document order, each after the calls that directly precede
    it (:func:`~task_agent.taskfile.precedes`: an earlier child of a sequence holding both;
    transitive orderings left out). Calls without an id get their path (``root.1.0``), as
    data flow names them."""
    sites = walk(assign_ids(task_file))
    before = [{j for j in range(i) if precedes(sites[j], site)} for i, site in enumerate(sites)]
    return [
        StepSpec(
            index=i,
            agent=site.call.agent,
            skill=site.call.skill,
            params=dict(site.call.params),
            after=tuple(sorted(j for j in before[i] if not any(j in before[k] for k in before[i]))),
            call_id=site.call.id,
            fallback_operator=site.call.fallback_operator,
        )
        for i, site in enumerate(sites)
    ]


def schedule(steps: Sequence[StepSpec], durations: Mapping[str, float]) -> list[StepSpec]:
    """``steps`` with estimated start and finish times (earliest start after predecessors;
    ``durations`` by skill, 1 s when unknown). ``steps`` must list predecessors first."""
    finish: dict[int, float] = {}
    out = []
    for s in steps:
        start = max((finish[p] for p in s.after if p in finish), default=0.0)
        finish[s.index] = start + durations.get(s.skill, 1.0)
        out.append(msgspec.structs.replace(s, start=start, finish=finish[s.index]))
    return out


class StepGraph:
    """The state of a set of steps: a step is ready when every predecessor succeeded."""

    def __init__(self, steps: Iterable[StepSpec]) -> None:
        self.steps = {s.index: s for s in steps}
        self.status: dict[int, StepStatus] = dict.fromkeys(self.steps, "waiting")

    def ready(self) -> list[StepSpec]:
        return [
            s
            for i, s in self.steps.items()
            if self.status[i] == "waiting"
            and all(self.status.get(p, "succeeded") == "succeeded" for p in s.after)
        ]

    def start(self, index: int) -> None:
        self.status[index] = "running"

    def finish(self, index: int, success: bool) -> None:
        self.status[index] = "succeeded" if success else "failed"

    @property
    def running(self) -> list[int]:
        return [i for i, st in self.status.items() if st == "running"]

    @property
    def complete(self) -> bool:
        return all(st == "succeeded" for st in self.status.values())


def resolve_params(
    params: Mapping[str, Value], ran: Mapping[str, Mapping[str, Value]], view: WorldView
) -> dict[str, Value]:
    """``params`` with ``"@<call id>.<param>"`` replaced by what that call ran with and
    ``"label:<label>"`` by the id of the one element with that label.

    Raises:
        StepInputError: the call has not run, has no such parameter, or the label matches
            no element or several.
    """
    out: dict[str, Value] = {}
    for name, value in params.items():
        ref = parse_ref(value)
        if ref is not None:
            if ref.step not in ran:
                raise StepInputError(f"{name}={value}: step {ref.step!r} has not run (yet)")
            if ref.param not in ran[ref.step]:
                have = ", ".join(sorted(ran[ref.step])) or "none"
                raise StepInputError(
                    f"{name}={value}: step {ref.step!r} has no parameter {ref.param!r} ({have})"
                )
            value = ran[ref.step][ref.param]
        elif isinstance(value, str) and value.startswith(LABEL_PREFIX):
            label = value[len(LABEL_PREFIX) :]
            found = sorted(e.id for e in view.resolve_element(Query(label=label)))
            if len(found) != 1:
                what = "no element" if not found else f"{len(found)} elements ({', '.join(found)})"
                raise StepInputError(f"{name}={value}: {what} with label {label!r}")
            value = found[0]
        out[name] = value
    return out


def unmet_goal(goal: Goal, view: WorldView) -> list[str]:
    """The goal's literals that do not hold in ``view``, each with the reason."""
    unmet = []
    for lit in goal.literals:
        cond: Condition
        if isinstance(lit, RelationGoal):
            cond = RelationCond(subject="s", predicate=lit.predicate, object="o", holds=lit.holds)
            bindings: dict[str, Value] = {"s": lit.subject, "o": lit.object}
        else:
            op: Literal["eq", "ne"] = "eq" if lit.holds else "ne"
            cond = PropertyCond(param="x", property=lit.property, op=op, value=lit.value)
            bindings = {"x": lit.element}
        verdict = evaluate(cond, view, bindings)
        if not verdict.ok:
            unmet.append(f"{lit} ({verdict.reason})")
    return unmet
