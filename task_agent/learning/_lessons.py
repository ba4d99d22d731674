"""What a task learned from its failed steps: :class:`Lessons`.

Each failed step (its agent, skill and parameters: one grounding) is kept with its reason,
the physical cause the skill reported (the run's message: "shoulder_lift ... blocked, or
overloaded?") and the state of the things it worked on: the world model's facts (properties
but poses, relations either way) about each parameter its post-conditions name
(:func:`changed_params`: a place's object and container, not the station it stood at, whose
relations change whenever a robot comes or goes) that is not the robot's own hardware.
The executor plans again without every grounding whose things are still in that state
(:func:`task_agent.planning.exclude_steps`): run again on the same things in the same state,
it would fail the same way, so one task never does that twice. Once the world model says
something new about them (a sensed part number, a container emptied), the step may be tried
again. A step the scheduler stopped, or one whose agent vanished or was not available, says
nothing about the step itself and is not kept (:data:`NOT_LEARNED`).

When no plan is left, :meth:`Lessons.explain` says why in words a person reads: each goal
fact that does not hold, and each step that failed, with the robot and the cause.
"""

from __future__ import annotations

from collections.abc import Callable, Collection, Iterable, Mapping
from typing import Protocol

import msgspec

from skill_agent import WorldView
from skill_agent.protocol import Condition, SkillDescription

__all__ = ["NOT_LEARNED", "FailedRun", "FailedStep", "Lessons", "changed_params", "state_of"]

NOT_LEARNED = frozenset({"stopped", "agent_lost", "preempted", "unavailable", "dataflow"})
"""Step outcome reasons that say nothing about the step itself."""
MOVING = frozenset({"pose", "position"})
"""Properties left out of a step's state: where a thing is carried is not what it is."""

_encode = msgspec.json.Encoder(order="sorted").encode


class FailedRun(Protocol):
    """A step's failure as the executor reports it (``StepOutcome`` is one)."""

    @property
    def agent(self) -> str: ...
    @property
    def skill(self) -> str: ...
    @property
    def params(self) -> Mapping[str, object]: ...
    @property
    def reason(self) -> str: ...
    @property
    def message(self) -> str: ...


def changed_params(description: SkillDescription) -> frozenset[str]:
    """The parameters a skill's post-conditions name (what it changes)."""
    names = {p.name for p in description.parameters}
    found: set[str] = set()

    def walk(cond: Condition) -> None:
        for attr in ("subject", "object", "param"):
            value = getattr(cond, attr, None)
            if isinstance(value, str) and value in names:
                found.add(value)
        for inner in [*getattr(cond, "items", ()), getattr(cond, "item", None)]:
            if inner is not None:
                walk(inner)

    for cond in description.post:
        walk(cond)
    return frozenset(found)


def state_of(view: WorldView, elements: Iterable[str]) -> bytes:
    """What the world model says about ``elements`` (properties but poses, relations)."""
    facts: list[object] = []
    for element in sorted(set(elements)):
        found = view.find_element(element)
        props = {k: v for k, v in (found.properties if found else {}).items() if k not in MOVING}
        relations = sorted(
            (r.subject, r.predicate, r.object)
            for r in [*view.query_relation(subject=element), *view.query_relation(obj=element)]
        )
        facts.append([element, found is not None, props, relations])
    return _encode(facts)


class FailedStep(msgspec.Struct, frozen=True, kw_only=True):
    agent: str
    skill: str
    params: dict[str, str]
    """The element parameters it ran with (parameter -> element id)."""
    reason: str
    cause: str
    """What the skill reported: the physical cause, in its words."""
    things: tuple[str, ...] = ()
    """The parameters' elements that are not the robot's hardware."""
    state: bytes = b""
    """:func:`state_of` those things when it failed."""
    shown: tuple[str, ...] = ()
    """The parameters' elements a person is told (all but the robot's hardware)."""

    def key(self) -> tuple[str, str, tuple[tuple[str, str], ...]]:
        return self.agent, self.skill, tuple(sorted(self.params.items()))

    def text(self, name: Callable[[str], str] = str) -> str:
        """``pick(object=..., holder=...) on r1 failed (execution): <cause>`` (the robot's own
        hardware left out of the parameters: the agent names the robot)."""
        args = ", ".join(f"{k}={name(v)}" for k, v in self.params.items() if v in self.shown)
        return f"{self.skill}({args}) on {self.agent} failed ({self.reason}): {self.cause}"


class Lessons:
    """The failed groundings of one task (see the module doc)."""

    def __init__(self) -> None:
        self.failed: list[FailedStep] = []

    def learn(
        self,
        view: WorldView,
        run: FailedRun,
        *,
        hardware: Collection[str] = (),
        changes: Collection[str] = (),
    ) -> FailedStep | None:
        """Keep this failure (None if its reason says nothing about the step), with the state
        of its things in ``view``: the parameters in ``changes`` (all when empty) but the
        robot's ``hardware``. A step that failed before in another state replaces that entry."""
        if run.reason in NOT_LEARNED or not run.agent or run.reason == "ok":
            return None
        elements = {k: v for k, v in run.params.items() if isinstance(v, str) and v}
        named = {v for k, v in elements.items() if not changes or k in changes}
        things = tuple(sorted(named - set(hardware)))
        step = FailedStep(
            agent=run.agent,
            skill=run.skill,
            params=elements,
            reason=run.reason,
            cause=run.message.strip() or "no message",
            things=things,
            state=state_of(view, things),
            shown=tuple(sorted(set(elements.values()) - set(hardware))),
        )
        self.failed = [f for f in self.failed if f.key() != step.key()] + [step]
        return step

    def excluded(self, view: WorldView) -> list[tuple[str, str, Mapping[str, object]]]:
        """(agent, skill, parameters) of every failed step whose things are in the state it
        failed in, for the planner."""
        return [
            (f.agent, f.skill, f.params) for f in self.failed if state_of(view, f.things) == f.state
        ]

    def explain(self, unmet: list[str], name: Callable[[str], str] = str) -> str:
        """Why the task ends: the goal facts that do not hold, and what was tried."""
        goal = "; ".join(unmet) or "the goal"
        if not self.failed:
            return f"no plan reaches {goal}"
        tried = "; ".join(f.text(name) for f in self.failed)
        return (
            f"nothing left to try for {goal}: no plan with the robots available reaches it "
            f"without a step that failed. Tried: {tried}"
        )
