"""Running a graph of steps on the agents: :class:`StepScheduler` (used by the executor).

A step starts as soon as every predecessor succeeded, on its agent, in a task of its own, so
steps with no ordering between them run at the same time on different robots. Each accepted
run is reported as ``StepStarted``, its progress as ``StepProgress``, its end as
``StepFinished`` (a refusal too, without ``StepStarted``).

After the first failure no step starts any more; the in-flight steps of the failed step's agent
(the failed branch) are stopped, the others finish, and :meth:`StepScheduler.run` returns the
failure. A step whose agent is lost (:class:`~task_agent.discovery.Discovery`: its token gone
while others stay, or not back within the grace period) is stopped at once and fails with
reason ``agent_lost``; the loss is recorded in :attr:`StepScheduler.lost` (which agent, at
which step) for a ``partial`` ending. A step whose agent is *unknown* (its token gone with
others': a lost router) waits before it starts until the agent is back or lost; its runs
already started go on. Cancelling :meth:`StepScheduler.run` (abort) stops every run: each ends
``preempted`` once the agent's ``on_preempt`` brought the robot to a safe state.

With :class:`~task_agent.execution.RunWrites` (the agents' event logs), each
``StepFinished`` lists the world-model revisions its run wrote (``wm_writes``: effects, a
skill's own transactions, its sub-runs'), and :attr:`StepScheduler.effects_revision` covers
them all.

Semi-autonomy: a step that failed (not refused by a false pre-condition, not stopped by the
scheduler) whose call allows it, or whose task does (``TaskOptions.operator_fallback`` for every
skill, ``operator_fallback_skills`` for the skills named), is handed to the operator agent: the
same skill with the parameters it ran with, plus ``operator_note`` saying what failed; a person
answers it (:mod:`task_agent.operator`) and a success counts as the step's success.

Giving way (:meth:`StepScheduler.give_way`, a preempted task): from then on only the ready
steps a policy picks start (the executor's: those finishing what a robot holds); once no step
of the task runs and the policy picks none, :meth:`StepScheduler.run` returns with
:attr:`StepScheduler.gave_way` set: a step boundary, nothing stopped mid-motion.

Pause (:attr:`StepScheduler.hold`, a :class:`~task_agent.execution._hold.Hold`): while the task
is held no step starts and the task's started runs are paused on their agents; releasing it
resumes them and starts the steps that became ready meanwhile.
"""

from __future__ import annotations

import math
import time
import uuid
from collections.abc import Awaitable, Callable
from contextlib import nullcontext
from typing import Any, TypeVar, cast

import anyio
import msgspec
from anyio.abc import TaskGroup
from anyio.streams.memory import MemoryObjectSendStream

from skill_agent import AgentTransportError, SkillError
from skill_agent.protocol import Progress, RunEvent, RunResult, RunStarted, StartRun
from wm_store.protocol import Value

from .._errors import StepInputError
from ..discovery import Discovery
from ..protocol import (
    LostAgent,
    StepFinished,
    StepProgress,
    StepStarted,
    TaskEvent,
    TaskOptions,
)
from ._history import EventHistory
from ._hold import Hold
from ._run_writes import RunWrites
from ._runners import SkillRunner
from ._state import (
    OPERATOR_NOTE,
    StepGraph,
    StepSpec,
    WorldModel,
    resolve_params,
)

__all__ = ["Boundary", "EventSink", "StepOutcome", "StepScheduler"]

E = TypeVar("E", bound=msgspec.Struct)

Boundary = Callable[[list[StepSpec], bool], Awaitable[list[StepSpec]]]
"""While a task gives way: ``(ready steps, whether a step runs)`` -> the ready steps that may
still start."""


class EventSink:
    """Numbers a task's events (``seq`` 1, 2, ...), stamps them, keeps them in ``history``
    (bounded, for late watchers) and publishes them."""

    def __init__(
        self,
        task_id: str,
        publish: Callable[[TaskEvent], None],
        history: EventHistory | None = None,
    ) -> None:
        self.task_id = task_id
        self.publish = publish
        self.history = history if history is not None else EventHistory()
        self.seq = 0

    def emit(self, kind: type[E], **fields: Any) -> E:
        self.seq += 1
        event = kind(task_id=self.task_id, seq=self.seq, stamp=time.time(), **fields)
        self.history.add(cast("TaskEvent", event))
        self.publish(cast("TaskEvent", event))
        return event


class StepOutcome(msgspec.Struct, kw_only=True):
    index: int
    agent: str
    skill: str
    success: bool
    reason: str
    message: str = ""
    stopped: bool = False
    """Stopped by the scheduler (the failed branch), not a failure of its own."""
    params: dict[str, Value] = {}
    wm_writes: list[int] = []
    outages: int = 0
    """``Discovery.outages`` when the step began: a later count means a lost router or a
    partition overlapped it (its failure may be the outage's, not the skill's)."""

    def __str__(self) -> str:
        text = f"step {self.index} {self.skill} on {self.agent or '?'}"
        return f"{text} failed ({self.reason}): {self.message}" if not self.success else text


class _Running(msgspec.Struct):
    agent: str
    scope: anyio.CancelScope
    why: tuple[str, str, bool] | None = None
    """(reason, message, stopped) when the scheduler stopped it."""


class StepScheduler:
    """Runs step graphs for one task (see the module docstring)."""

    def __init__(
        self,
        *,
        events: EventSink,
        runner: SkillRunner,
        discovery: Discovery,
        wm: WorldModel,
        options: TaskOptions,
        operator_agent: str = "",
        writes: RunWrites | None = None,
    ) -> None:
        self.events = events
        self.writes = writes
        self.runner = runner
        self.discovery = discovery
        self.wm = wm
        self.options = options
        self.operator_agent = operator_agent
        self.ran: dict[str, dict[str, Value]] = {}
        """Call id -> the parameters it ran with (task-file data flow)."""
        self.steps_run = 0
        self.succeeded: set[int] = set()
        """Indices of the steps that ran to success."""
        self.effects_revision = 0
        self.hold = Hold(runner, events.task_id)
        """The task-level pause (see the module doc)."""
        self.used: set[str] = set()
        """The agents that ran a step of the task (the task's robots)."""
        self.lost: dict[str, LostAgent] = {}
        """The task's agents lost while it ran (the first loss of each)."""
        self._planned_agents: set[str] = set()
        self._running: dict[int, _Running] = {}
        self._wake: MemoryObjectSendStream[StepOutcome | None] | None = None
        self._tg: TaskGroup | None = None
        self._boundary: Boundary | None = None
        self.gave_way = False
        """The last :meth:`run` returned at a step boundary to give way (its graph not done)."""

    def give_way(self, boundary: Boundary) -> None:
        """Make :meth:`run` return at the next step boundary: from now on start only the
        ready steps ``boundary`` picks; once no step runs and it picks none, return (with
        :attr:`gave_way` set). Lasts until :meth:`run` returns."""
        self._boundary = boundary
        if self._wake is not None:
            self._wake.send_nowait(None)

    async def pause(self, reason: str = "") -> list[str] | None:
        """Hold the task (no step starts) and pause its started runs; returns them
        (``agent/run``), or None if it was held already."""
        if self.hold.held:
            return None
        return await self.hold.hold(reason)

    async def resume(self) -> list[str] | None:
        """Release the task: resume the runs the pause held, start the ready steps; returns
        the runs resumed, or None if the task was not held."""
        if not self.hold.held:
            return None
        resumed = await self.hold.release()
        if self._wake is not None:
            self._wake.send_nowait(None)
        return resumed

    async def run(self, steps: list[StepSpec]) -> StepOutcome | None:
        """Run ``steps``; returns the first failure, or None when every step succeeded."""
        graph = StepGraph(steps)
        self._planned_agents = {s.agent for s in steps if s.agent}
        failure: StepOutcome | None = None
        self.gave_way = False
        send, receive = anyio.create_memory_object_stream[StepOutcome | None](math.inf)
        unsubscribe = self.discovery.on_presence(self._presence)
        try:
            with send, receive:
                async with anyio.create_task_group() as tg:
                    self._wake, self._tg = send, tg
                    while True:
                        ready = graph.ready() if self._may_start(failure) else []
                        if self._boundary is not None and ready:
                            ready = await self._boundary(ready, bool(graph.running))
                        for spec in ready:
                            graph.start(spec.index)
                            tg.start_soon(self._step, spec, send, name=f"task step {spec}")
                        if not graph.running:
                            if self._boundary is not None and failure is None:
                                self.gave_way = not graph.complete
                                break
                            if failure is None and self.hold.held and graph.ready():
                                await self.hold.wait()
                                continue
                            break
                        outcome = await receive.receive()
                        if outcome is None:  # resumed: start what became ready
                            continue
                        graph.finish(outcome.index, outcome.success)
                        if not outcome.success and failure is None:
                            failure = outcome
                            why = f"stopped because {outcome}"
                            self._stop(outcome.agent, "stopped", why, True)
        finally:
            self._wake = self._tg = None
            self._boundary = None
            unsubscribe()
        return failure

    def _may_start(self, failure: StepOutcome | None) -> bool:
        return failure is None and not self.hold.held

    # ------------------------------------------------------------------ one step

    async def _step(self, spec: StepSpec, done: MemoryObjectSendStream[StepOutcome | None]) -> None:
        outcome = await self._attempt(spec, spec.agent or self._choose(spec.skill))
        if self._fallback_allowed(spec, outcome):
            note = f"task {self.events.task_id}, {outcome}. Please do it by hand."
            outcome = await self._attempt(
                spec, self.operator_agent, params={**outcome.params, OPERATOR_NOTE: note}
            )
        done.send_nowait(outcome)

    def _choose(self, skill: str) -> str:
        """An available agent offering ``skill``, idle ones (in this task) first."""
        busy = {r.agent for r in self._running.values()}
        names = [a.name for a in self.discovery.offering(skill)]
        return next((n for n in names if n not in busy), names[0] if names else "")

    def _fallback_allowed(self, spec: StepSpec, outcome: StepOutcome) -> bool:
        allowed = (
            spec.fallback_operator
            or self.options.operator_fallback
            or spec.skill in self.options.operator_fallback_skills
        )
        return (
            allowed
            and not outcome.success
            and not outcome.stopped
            and outcome.reason not in ("precondition", "dataflow")
            and bool(self.operator_agent)
            and outcome.agent != self.operator_agent
            and self.discovery.is_alive(self.operator_agent)
        )

    async def _attempt(
        self, spec: StepSpec, agent: str, *, params: dict[str, Value] | None = None
    ) -> StepOutcome:
        by_operator = params is not None and agent == self.operator_agent
        await self.hold.wait()  # a step spawned just before a pause starts after it
        outcome = StepOutcome(
            index=spec.index,
            agent=agent,
            skill=spec.skill,
            success=False,
            reason="unavailable",
            outages=self.discovery.outages,
        )
        try:
            outcome.params = params or resolve_params(spec.params, self.ran, self.wm)
        except StepInputError as e:
            outcome.reason, outcome.message = "dataflow", str(e)
            return self._finished(outcome, by_operator)
        if not agent:
            outcome.message = f"no available agent offers {spec.skill!r}"
            return self._finished(outcome, by_operator)
        await self.discovery.wait_known(agent)  # out of reach: back, or lost, within the grace
        if not self.discovery.is_alive(agent):
            outcome.message = f"agent {agent} is not available (no liveliness token)"
            return self._finished(outcome, by_operator)
        request = StartRun(
            skill=spec.skill,
            params=outcome.params,
            run_id=uuid.uuid4().hex[:16],
            simulate=self.options.simulate,
            author=f"task {self.events.task_id}",
        )
        results: list[RunResult] = []

        def on_started(started: RunStarted) -> None:
            if self.hold.started(agent, started.run_id) and self._tg is not None:
                self._tg.start_soon(self.hold.pause_run, agent, started.run_id)
            self.steps_run += 1
            self.used.add(agent)
            outcome.params = dict(started.params)
            if spec.call_id:
                self.ran[spec.call_id] = dict(started.params)
            self.events.emit(
                StepStarted,
                step=spec.index,
                agent=agent,
                skill=spec.skill,
                run_id=started.run_id,
                params=dict(started.params),
            )

        def on_event(event: RunEvent) -> None:
            if isinstance(event, Progress):
                self.events.emit(
                    StepProgress,
                    step=spec.index,
                    agent=agent,
                    state=event.state,
                    message=event.message,
                    fraction=event.fraction,
                )
            else:
                results.append(event)

        running = self._running[spec.index] = _Running(agent, anyio.CancelScope())
        watch = self.writes.watch(agent, request.run_id) if self.writes else nullcontext()
        with watch as watched:
            try:
                with running.scope:
                    try:
                        results.append(
                            await self.runner.run(
                                agent, request, on_started=on_started, on_event=on_event
                            )
                        )
                    except AgentTransportError as e:
                        outcome.reason, outcome.message = "agent_lost", str(e)
                    except SkillError as e:
                        reason = "precondition" if e.code == "precondition" else e.code
                        outcome.reason, outcome.message = reason, str(e)
                if watched is not None and self.writes is not None:  # refused: nothing to wait
                    writes = await self.writes.revisions(watched) if results else watched.revisions
                    self._wrote(outcome, writes)
            except anyio.get_cancelled_exc_class():  # abort: the run was stopped on the agent
                self._from_result(outcome, results, "preempted", "the task was aborted")
                self._wrote(outcome, watched.revisions if watched is not None else [])
                self._finished(outcome, by_operator)
                raise
            finally:
                self._running.pop(spec.index, None)
                self.hold.ended(request.run_id)
        reason, message, outcome.stopped = running.why or ("", "", False)
        self._from_result(outcome, results, reason, message)
        return self._finished(outcome, by_operator)

    def _wrote(self, outcome: StepOutcome, revisions: list[int]) -> None:
        outcome.wm_writes = list(revisions)
        self.effects_revision = max(self.effects_revision, *revisions, 0)

    def _from_result(
        self, outcome: StepOutcome, results: list[RunResult], reason: str, message: str
    ) -> None:
        """Fill ``outcome`` from the run's result; ``reason``: the scheduler stopped the run
        (the result, if any, is kept in the message)."""
        result = results[-1] if results else None
        if result is not None:
            self.effects_revision = max(self.effects_revision, result.effects_revision)
            outcome.success, outcome.reason = result.success, result.reason
            outcome.message = result.message
        if reason:
            detail = f" (run: {outcome.reason}: {outcome.message})" if result else ""
            outcome.success, outcome.reason, outcome.message = False, reason, message + detail

    def _finished(self, outcome: StepOutcome, by_operator: bool) -> StepOutcome:
        if outcome.success:
            self.succeeded.add(outcome.index)
        if outcome.reason == "agent_lost":
            self._record_loss(outcome.agent, outcome.index, outcome.skill, outcome.message)
        self.events.emit(
            StepFinished,
            step=outcome.index,
            agent=outcome.agent,
            skill=outcome.skill,
            success=outcome.success,
            reason=outcome.reason,
            message=outcome.message,
            by_operator=by_operator,
            wm_writes=outcome.wm_writes,
        )
        return outcome

    # ------------------------------------------------------------------ stopping

    def _stop(self, agent: str, reason: str, message: str, stopped: bool) -> None:
        for running in self._running.values():
            if running.agent == agent and running.why is None:
                running.why = (reason, message, stopped)
                running.scope.cancel()

    def _record_loss(self, agent: str, step: int, skill: str, message: str) -> None:
        if agent and agent not in self.lost:
            self.lost[agent] = LostAgent(agent=agent, step=step, skill=skill, message=message)

    def _presence(self, agent: str, alive: bool) -> None:
        if alive:
            return
        message = f"agent {agent} vanished (liveliness)"
        if agent in self._planned_agents | self.used and not any(
            r.agent == agent for r in self._running.values()
        ):
            self._record_loss(agent, -1, "", message + " between its steps")
        self._stop(agent, "agent_lost", message, False)
