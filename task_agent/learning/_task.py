"""One task's learning: :class:`TaskLearning`, the executor's hook.

It follows the task's events (:meth:`TaskLearning.observe`: the executor hands it each event
as it publishes it): every step that succeeded adds its time to the shared
:class:`DurationBook` (its distance too when it drives): from the moment it could start (its
plan was made, or its last predecessor finished) to its ``StepFinished``, on the task agent's
clock. That is the time the schedule has to allow for it: the run, and the start before it
(the request, the agent's pre-sensing and pre-condition check), which a run's own clock
leaves out; the first plan's makespan is the task's estimate, and the time from
that plan to the end of its last step the actual makespan (replans, their planning and their
steps included). A failed step becomes a :class:`Lessons` entry (:meth:`TaskLearning.failed`).
"""

from __future__ import annotations

from collections.abc import Iterable, Mapping

import anyio
import msgspec

from skill_agent import WorldView
from wm_store import display_name

from ..discovery import AgentInfo
from ..protocol import Planned, StepFinished, StepStarted, TaskEvent
from ._durations import DurationBook
from ._lessons import FailedRun, FailedStep, Lessons, changed_params
from ._timing import StepTimer, positions, route

__all__ = ["Makespans", "TaskLearning"]


class Makespans(msgspec.Struct, frozen=True, kw_only=True):
    estimated: float
    """The first plan's makespan, s."""
    actual: float
    """From the first plan to the end of the task's last step, s."""


class _Started(msgspec.Struct, frozen=True):
    stamp: float
    agent: str
    skill: str
    metres: float | None


class TaskLearning:
    """What one task feeds into the learned knowledge and takes from it (module doc)."""

    def __init__(self, book: DurationBook, view: WorldView) -> None:
        self.book = book
        self.view = view
        self.lessons = Lessons()
        self.estimated: float | None = None
        self._planned_at = 0.0
        self._last_end = 0.0
        self._started: dict[int, _Started] = {}
        self._after: dict[int, tuple[int, ...]] = {}
        self._planned: dict[int, float] = {}
        """Step -> when its plan was made."""
        self._ended: dict[int, float] = {}

    # ------------------------------------------------------------------ planning

    def timer(self, objects: Iterable[str]) -> StepTimer:
        """Step estimates for a plan over ``objects`` (reads poses: call on the loop)."""
        return StepTimer(self.book, positions(self.view, objects))

    def failed(self, run: FailedRun, agent: AgentInfo | None) -> FailedStep | None:
        """Learn from a step that failed on ``agent`` (call once the world model shows its
        effects): the things it changes are its skill's post-conditions' parameters but the
        agent's hardware (see :class:`Lessons`)."""
        if agent is None:
            return self.lessons.learn(self.view, run)
        skill = agent.skill(run.skill)
        changes = changed_params(skill) if skill is not None else frozenset()
        return self.lessons.learn(self.view, run, hardware=agent.hardware, changes=changes)

    def nothing_left(self, unmet: list[str]) -> str:
        """Why the task ends after its failed steps, in words (labels, no action names)."""

        def name(element: str) -> str:
            found = self.view.find_element(element)
            return display_name(found) if found is not None else element

        return self.lessons.explain(unmet, name)

    def excluded(self) -> list[tuple[str, str, Mapping[str, object]]]:
        """The failed steps the next plan must not contain (see :class:`Lessons`)."""
        return self.lessons.excluded(self.view)

    # ------------------------------------------------------------------ events

    def observe(self, event: TaskEvent) -> None:
        match event:
            case Planned():
                if self.estimated is None:
                    self.estimated, self._planned_at = event.makespan, event.stamp
                for step in event.steps:
                    self._after[step.index] = tuple(step.after)
                    self._planned[step.index] = event.stamp
            case StepStarted():
                where = positions(
                    self.view, [v for v in event.params.values() if isinstance(v, str)]
                )
                metres = route(where, event.params)
                self._started[event.step] = _Started(event.stamp, event.agent, event.skill, metres)
            case StepFinished():
                began = self._started.pop(event.step, None)
                self._ended[event.step] = event.stamp
                if began is None:
                    return
                self._last_end = max(self._last_end, event.stamp)
                if event.success and not event.by_operator and began.agent == event.agent:
                    ready = max(
                        (self._ended.get(p, 0.0) for p in self._after.get(event.step, ())),
                        default=self._planned.get(event.step, began.stamp),
                    )
                    self.book.record(began.agent, began.skill, event.stamp - ready, began.metres)
            case _:
                pass

    def makespans(self) -> Makespans | None:
        """Estimated and actual makespan (None before the first plan)."""
        if self.estimated is None:
            return None
        actual = max(self._last_end - self._planned_at, 0.0)
        return Makespans(estimated=self.estimated, actual=actual)

    def makespan_fields(self, *, ended: bool) -> dict[str, float]:
        """``estimated_makespan`` (once planned) and, once ``ended``, ``actual_makespan``:
        the fields of ``TaskInfo`` / ``TaskFinished``."""
        found = self.makespans()
        if found is None:
            return {}
        if not ended:
            return {"estimated_makespan": found.estimated}
        return {"estimated_makespan": found.estimated, "actual_makespan": found.actual}

    async def save(self) -> None:
        """Keep the book (its file, in a worker thread)."""
        if self.book.path is not None:
            await anyio.to_thread.run_sync(self.book.save, self.book.snapshot())
