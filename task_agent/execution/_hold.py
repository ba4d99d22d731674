"""A task-level pause: :class:`Hold`, used by the step scheduler.

While a task is held no new step starts (a step whose predecessors are done waits), and every
run of the task that has started is paused on its agent (:meth:`SkillRunner.pause
<task_agent.execution.SkillRunner.pause>`: the agent holds it at its next checkpoint); a run
whose start was in flight is paused as soon as its agent accepts it. :meth:`Hold.release`
resumes the runs it paused and lets the waiting steps start. Aborting a held task stops its
runs as usual (a paused run can be stopped). A run that ended meanwhile, or an agent that
refuses, is logged and skipped: pausing is best effort per run, holding new steps is not.
"""

from __future__ import annotations

import logging
from collections.abc import Awaitable, Callable

import anyio

from skill_agent import SkillError

from ._runners import SkillRunner

__all__ = ["Hold"]

_log = logging.getLogger(__name__)


class Hold:
    """Whether a task is held, and the runs it paused (see the module doc)."""

    def __init__(self, runner: SkillRunner, task_id: str = "") -> None:
        self.runner = runner
        self.task_id = task_id
        self.reason = ""
        self._released = anyio.Event()
        self._released.set()
        self._runs: dict[str, str] = {}
        """Started runs of the task: run id -> agent."""
        self._paused: dict[str, str] = {}
        """Runs paused on their agents by this hold: run id -> agent."""

    @property
    def held(self) -> bool:
        return not self._released.is_set()

    async def wait(self) -> None:
        """Return once the task is not held (at once if it is not)."""
        while self.held:
            await self._released.wait()

    def started(self, agent: str, run_id: str) -> bool:
        """A run of the task started; True if it must be paused now (the task is held)."""
        self._runs[run_id] = agent
        return self.held

    def ended(self, run_id: str) -> None:
        self._runs.pop(run_id, None)
        self._paused.pop(run_id, None)

    async def hold(self, reason: str = "") -> list[str]:
        """Hold the task and pause its started runs; returns them as ``agent/run`` (empty if
        it was held already)."""
        if self.held:
            return []
        self.reason, self._released = reason, anyio.Event()
        return await _each(self._runs, self.pause_run)

    async def pause_run(self, agent: str, run_id: str) -> bool:
        """Pause one run on its agent (if the task is still held and the run still runs)."""
        if not self.held or run_id not in self._runs or run_id in self._paused:
            return False
        if not await self._ask(self.runner.pause, agent, run_id):
            return False
        if run_id not in self._runs:  # ended while the request was out
            return False
        self._paused[run_id] = agent
        if self._released.is_set():  # released meanwhile: let it go on
            await self._resume_run(agent, run_id)
            return False
        return True

    async def release(self) -> list[str]:
        """Resume the runs this hold paused and let new steps start; returns the runs
        resumed as ``agent/run`` (empty if the task was not held)."""
        if not self.held:
            return []
        self.reason = ""
        self._released.set()
        return await _each(self._paused, self._resume_run)

    async def _resume_run(self, agent: str, run_id: str) -> bool:
        self._paused.pop(run_id, None)
        return await self._ask(self.runner.resume, agent, run_id)

    async def _ask(
        self, call: Callable[[str, str], Awaitable[None]], agent: str, run_id: str
    ) -> bool:
        """``call(agent, run_id)``; False (logged) if the agent refused or is gone."""
        try:
            await call(agent, run_id)
        except SkillError as e:
            what = call.__name__
            _log.info(
                "task %s: could not %s run %s on %s: %s", self.task_id, what, run_id, agent, e
            )
            return False
        return True


async def _each(runs: dict[str, str], act: Callable[[str, str], Awaitable[bool]]) -> list[str]:
    """``act(agent, run_id)`` for each of ``runs`` (run id -> agent); the runs it acted on,
    as ``agent/run``."""
    return [f"{agent}/{run_id}" for run_id, agent in list(runs.items()) if await act(agent, run_id)]
