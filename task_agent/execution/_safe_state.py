"""The executor's **safe-state phase**: when a task ends unfinished, its robots put down what
they hold (:class:`SafeStatePhase`).

A task ends unfinished when it is ``partial``, ``failed`` or ``aborted`` (the service shutting
down is not a task ending: it stops every run and leaves). By then nothing of the task runs any
more: an abort stopped every run, a failure stopped the failed branch and let the others end,
and a stopped run ends once its skill's ``on_preempt`` brought the hardware to rest (the skill
layer's part). What is left is what the robots hold.

For each agent that ran a step of the task and is still alive, the phase reads from the world
model what its devices hold (``contain(<device>, <object>)``, e.g. a gripper holding a gear).
For each robot holding something it plans, with that agent alone and only its skills that
leave the robot where it stands (no post-condition moves it: ``at``), the goal
``not contain(<device>, <object>)``: a place into a container it carries or one at its current
station, or onto a free surface there, whatever its skills offer and the world model allows.
The plans of every robot run together as ordinary steps (``StepStarted`` / ``StepFinished``,
numbered after the task's steps); then one :class:`~task_agent.protocol.SafeState` event per
robot says what it held and whether it put it down, or why it could not (no such skill, no
free place in reach, the put-down failed, the agent is gone). The phase is bounded
(``within`` seconds); a robot still holding something then is reported as such.
"""

from __future__ import annotations

import logging
from collections.abc import Callable
from typing import TYPE_CHECKING

import anyio
import msgspec

from skill_agent.protocol import RelationCond

from .._errors import TaskError
from .._goals import Goal, RelationGoal
from ..discovery import AgentInfo, Discovery
from ..planning import PartialOrderPlan, to_partial_order
from ..protocol import SafeState
from ._state import StepSpec, WorldModel
from ._steps import EventSink, StepOutcome, StepScheduler

if TYPE_CHECKING:
    from ._task_planning import PlanSource

__all__ = ["CONTAIN", "SafeStatePhase", "held_by"]

_log = logging.getLogger(__name__)

CONTAIN = "contain"


def held_by(agent: AgentInfo, view: WorldModel) -> list[tuple[str, str]]:
    """What ``agent``'s devices hold: ``(device, object)`` pairs, from the world model."""
    return [
        (device, rel.object)
        for device in agent.devices
        for rel in view.query_relation(device, CONTAIN)
    ]


def _staying(agent: AgentInfo) -> AgentInfo:
    """``agent`` with only the skills that leave its robot where it stands."""
    skills = tuple(
        s
        for s in agent.skills
        if not any(isinstance(c, RelationCond) and c.predicate == "at" for c in s.post)
    )
    return msgspec.structs.replace(agent, skills=skills)


class SafeStatePhase:
    """Puts down what the task's robots hold (see the module docstring). ``number(steps)``
    turns a plan into steps with their task-wide indices."""

    def __init__(
        self,
        *,
        wm: WorldModel,
        discovery: Discovery,
        steps: StepScheduler,
        events: EventSink,
        planner: PlanSource | None,
        number: Callable[[PartialOrderPlan], list[StepSpec]],
        within: float = 120.0,
    ) -> None:
        self.wm = wm
        self.discovery = discovery
        self.steps = steps
        self.events = events
        self.planner = planner
        self.number = number
        self.within = within

    async def run(self, agents: set[str]) -> list[SafeState]:
        """Bring the robots of ``agents`` that hold something to a safe state; returns the
        events published (one per robot that held something)."""
        reports: list[SafeState] = []
        planned: dict[str, list[tuple[str, str]]] = {}
        to_run: list[StepSpec] = []
        for name in sorted(agents):
            info = self.discovery.agent(name)
            holding = held_by(info, self.wm) if info is not None else []
            if info is None or not holding:
                continue
            if not self.discovery.is_alive(name):
                reports.append(self._report(name, holding, False, f"agent {name} is gone"))
                continue
            try:
                steps = await self._plan(info, holding)
            except TaskError as e:
                why = f"no way to put it down where {name} stands: {e}"
                reports.append(self._report(name, holding, False, why))
                continue
            planned[name] = holding
            to_run += steps
        failure: StepOutcome | None = None
        if to_run:
            with anyio.move_on_after(self.within):
                failure = await self.steps.run(to_run)
            await self._catch_up()
        for name, holding in planned.items():
            info = self.discovery.agent(name)
            still = held_by(info, self.wm) if info is not None else holding
            if still:
                why = f"the put-down did not free {', '.join(self._label(o) for _, o in still)}"
                if failure is not None and failure.agent == name:
                    why += f": {failure}"
                reports.append(self._report(name, holding, False, why))
            else:
                reports.append(self._report(name, holding, True, "put down"))
        return reports

    async def _plan(self, info: AgentInfo, holding: list[tuple[str, str]]) -> list[StepSpec]:
        if self.planner is None:
            raise TaskError("this executor has no planner")
        goal = Goal(
            literals=tuple(
                RelationGoal(predicate=CONTAIN, subject=d, object=o, holds=False)
                for d, o in holding
            )
        )
        plan = await self.planner.plan([_staying(info)], self.wm, goal)
        return self.number(await anyio.to_thread.run_sync(to_partial_order, plan))

    async def _catch_up(self) -> None:
        try:
            await self.wm.wait_for_revision(self.steps.effects_revision, timeout=5.0)
        except TimeoutError:
            _log.warning("the world model did not show the put-downs' effects within 5 s")

    def _label(self, element_id: str) -> str:
        element = self.wm.find_element(element_id)
        return element.label if element is not None and element.label else element_id

    def _report(
        self, agent: str, holding: list[tuple[str, str]], ok: bool, message: str
    ) -> SafeState:
        texts = [self._label(o) for _, o in holding]
        if not ok:
            _log.warning("safe state of %s (holding %s): %s", agent, ", ".join(texts), message)
        return self.events.emit(SafeState, agent=agent, holding=texts, ok=ok, message=message)
