"""One task from start to finish: :class:`Executor`.

A **goal** is planned from the current world model with the agents discovery offers, the plan
becomes a partial order (:func:`~task_agent.planning.to_partial_order`) and its steps run
as soon as their predecessors are done (:class:`~task_agent.execution.StepScheduler`: steps on
different robots in parallel). When a step fails (a pre-, post- or hold-condition, a skill
error, a time-out, the agent's liveliness token gone) the failed branch is stopped, the other
in-flight steps finish, and the goal is **planned again from the world model as it is now**
with the agents still there, at most ``TaskOptions.max_replans`` times; an agent's skill that
failed on its own (``execution``, ``error``, ``timeout``) is left out of later plans of the task
unless no plan exists without it. When every step succeeded the goal is checked in the world
model: if it does not hold, that is a failure too. Each reason is published in a
``Replanning`` event and listed in the final message. A goal that holds is then checked fact by
fact (``verify``: in the world model and, where a simulator runs, in the physics; see
:mod:`task_agent._physics`), and the result travels in ``TaskFinished.check`` and
``TaskInfo.check``; the outcome stays ``succeeded`` (the plan ran and the world model holds the
goal), and the clients judge a contradicting physics.

A **task file** (hand-written sequence / parallel blocks, verified by the service before it gets
here) runs as written; a failed step fails the task (there is no goal to plan towards), unless
the operator takes the step over (semi-autonomy, see ``_steps``).

When a replan after a **lost agent** finds no plan for the whole goal, the goal facts the
agents left can still reach are pursued (:meth:`Executor._salvage`: the facts that hold, then
each open fact a plan still reaches together with those kept), and the task ends ``partial``
with a :class:`~task_agent.protocol.PartialResult` (facts achieved, facts lost and why, agents
lost at which step). Before planning, agents of unknown state (a lost router, a partition:
:class:`~task_agent.discovery.Discovery`) are waited for, within the grace period; a step that
failed while such an outage lasted does not leave its skill out of later plans.

A task that ends unfinished (``partial``, ``failed``, ``aborted``) then runs the **safe-state
phase** (:class:`~task_agent.execution.SafeStatePhase`): its robots put down what they hold.

Learning (:mod:`task_agent.learning`, :attr:`Executor.learning`): every event passes the
task's :class:`~task_agent.learning.TaskLearning` before it is published (run times into the
shared :class:`~task_agent.learning.DurationBook`, saved when the task ends; estimated and
actual makespan on ``TaskFinished`` / ``TaskInfo``); plans are timed from the book; a failed
step is kept with its cause and the state of its things, and later plans exclude it while that
state holds, so no step fails the same way twice in a task; with nothing else left the task
ends saying which step failed on which robot and why.

**Claims** (:mod:`task_agent.claims`, ``claims``): before its steps run, a task holds the
agents and objects they need, waiting while another task holds any of them (``waiting`` says
for what); a task that had to wait plans again from the world model as it is once its claim
is granted (the other task changed it meanwhile). **Preemption** (``preemption`` and
``TaskOptions.preemptible``, both on by default; goals only, not task files): when a task of
higher priority waits for what this one holds, this task gives way at its next step boundary
(:meth:`StepScheduler.give_way <task_agent.execution.StepScheduler.give_way>`: its steps in
flight finish, then only steps that finish what one of its robots holds start, so no robot
is left holding a part), gives its claim back and waits (``TaskPaused`` with the reason;
``waiting`` says preempted by which task), re-acquires its claim (``TaskResumed``) and plans
again from the world model as it is; neither the wait nor the new plan counts as a replan.

Events, in ``seq`` order: ``TaskStarted``, ``Planned`` (per attempt), ``StepStarted`` /
``StepProgress`` / ``StepFinished``, ``Replanning``, ``SafeState`` (after an unfinished
ending), one ``TaskFinished``.
:meth:`Executor.abort` stops every run of the task (each agent brings its robot to a safe
state) and ends it ``aborted``; so does cancelling the executor (the service shutting down).
:meth:`Executor.pause` holds the task (no new step starts, its runs are paused on their agents;
``TaskPaused``) until :meth:`Executor.resume` (``TaskResumed``); abort works while paused.
Every event is kept in :attr:`Executor.history` (bounded: :mod:`._history`).
"""

from __future__ import annotations

import logging
import time
from collections.abc import Awaitable, Callable

import anyio

from .._errors import DomainError, PlanningError, UnsolvableError
from .._goals import Goal
from ..claims import ClaimBook
from ..discovery import Discovery
from ..learning import DurationBook, FailedStep, TaskLearning
from ..protocol import (
    GoalCheck,
    LostFact,
    PartialResult,
    Planned,
    Replanning,
    TaskEvent,
    TaskFile,
    TaskFinished,
    TaskInfo,
    TaskOptions,
    TaskOutcome,
    TaskPaused,
    TaskResumed,
    TaskStarted,
)
from ._claiming import TaskClaims
from ._history import MAX_TASK_EVENTS, EventHistory
from ._run_writes import RunWrites
from ._runners import SkillRunner
from ._safe_state import SafeStatePhase
from ._salvage import partial_ending, partial_result, still_reachable
from ._state import (
    WorldModel,
    schedule,
    steps_from_file,
    unmet_goal,
)
from ._steps import EventSink, StepOutcome, StepScheduler
from ._task_planning import PlanSource, TaskPlanning

__all__ = ["EXCLUDED_REASONS", "Executor", "GoalVerifier"]

_log = logging.getLogger(__name__)

EXCLUDED_REASONS = frozenset({"execution", "error", "timeout"})
"""Failures that say the agent's skill itself failed (not the world model): that skill of
that agent is left out of the task's later plans."""


GoalVerifier = Callable[[Goal], Awaitable[GoalCheck]]
"""Checks a goal that holds in the world model, fact by fact (world model and physics)."""


class Executor:
    """Runs one task (see the module docstring). Call :meth:`run_goal` or :meth:`run_file`
    once; :meth:`abort` and :meth:`info` from anywhere on the loop."""

    def __init__(
        self,
        *,
        task_id: str,
        wm: WorldModel,
        discovery: Discovery,
        runner: SkillRunner,
        publish: Callable[[TaskEvent], None],
        options: TaskOptions | None = None,
        planner: PlanSource | None = None,
        operator_agent: str = "operator",
        wm_timeout: float = 5.0,
        agent_wait: float = 5.0,
        writes: RunWrites | None = None,
        verify: GoalVerifier | None = None,
        max_events: int = MAX_TASK_EVENTS,
        claims: ClaimBook | None = None,
        durations: DurationBook | None = None,
        preemption: bool = True,
    ) -> None:
        self.task_id = task_id
        self.claims = claims
        """The task service's claims: this task holds its agents and objects while it runs
        and waits for those another task holds (None: no other task shares the site)."""
        self.learning = TaskLearning(durations or DurationBook(), wm)
        """The learning hook: run times into ``durations``, failed steps, makespans."""
        self.verify = verify
        self.check: GoalCheck | None = None
        """The goal's facts checked after success (``verify``), once there."""
        self.wm = wm
        self.discovery = discovery
        self.options = options or TaskOptions()
        self.planner = planner
        self.wm_timeout = wm_timeout
        self.agent_wait = agent_wait
        """Seconds to wait for an agent when none is available (a router restart makes every
        liveliness token vanish for a few seconds)."""
        self.history = EventHistory(max_events)
        """The task's events so far (at most ``max_events``)."""
        self.events = EventSink(task_id, _observed(publish, self.learning), self.history)
        self.steps = StepScheduler(
            events=self.events,
            runner=runner,
            discovery=discovery,
            wm=wm,
            options=self.options,
            operator_agent=operator_agent,
            writes=writes,
        )
        self.goal = ""
        self.name = ""
        self.outcome: TaskOutcome = "running"
        self.message = ""
        self.reasons: list[str] = []
        """Why each replan happened."""
        self.started_at = time.time()
        self.finished_at = 0.0
        self.partial: PartialResult | None = None
        """What a task that lost an agent achieved and lost (``partial``), once it ended."""
        self.claiming = TaskClaims(
            book=claims,
            steps=self.steps,
            events=self.events,
            discovery=discovery,
            wm=wm,
            priority=self.options.priority,
            preemptible=preemption and self.options.preemptible,
            catch_up=self._catch_up,
        )
        """This task's side of ``claims``: claiming, waiting, giving way."""
        self.plans = TaskPlanning(
            task_id=task_id,
            planner=planner,
            wm=wm,
            discovery=discovery,
            learning=self.learning,
            claiming=self.claiming,
            steps=self.steps,
            events=self.events,
            catch_up=self._catch_up,
            agent_wait=agent_wait,
        )
        """Its plans: made around what other tasks hold, timed, numbered, announced."""
        self.safe_state = SafeStatePhase(
            wm=wm,
            discovery=discovery,
            steps=self.steps,
            events=self.events,
            planner=planner,
            number=self.plans.steps_of,
        )
        self._scope = anyio.CancelScope()
        self._abort_reason = ""

    # ------------------------------------------------------------------ public

    @property
    def replans(self) -> int:
        return len(self.reasons)

    def abort(self, reason: str = "") -> None:
        """Stop every run of the task and end it ``aborted`` (returns at once)."""
        if self.outcome == "running" and not self._abort_reason:
            self._abort_reason = reason or "aborted on request"
            self._scope.cancel()

    @property
    def waiting(self) -> str:
        """What the task waits for before its steps can start ("" when it waits for none)."""
        return self.claiming.waiting

    @property
    def paused(self) -> bool:
        return self.steps.hold.held

    async def pause(self, reason: str = "") -> bool:
        """Hold the task: no new step starts, its started runs are paused on their agents
        (``TaskPaused``). False if it was held already or has ended."""
        if self.outcome != "running":
            return False
        runs = await self.steps.pause(reason)
        if runs is None:
            return False
        self.events.emit(TaskPaused, reason=reason, runs=runs)
        return True

    async def resume(self) -> bool:
        """Release a held task: its paused runs go on, new steps start (``TaskResumed``).
        False if it was not held."""
        runs = await self.steps.resume()
        if runs is None:
            return False
        if self.outcome == "running":
            self.events.emit(TaskResumed, runs=runs)
        return True

    def info(self) -> TaskInfo:
        return TaskInfo(
            task_id=self.task_id,
            outcome=self.outcome,
            goal=self.goal,
            name=self.name,
            started_at=self.started_at,
            finished_at=self.finished_at,
            replans=self.replans,
            steps_run=self.steps.steps_run,
            message=self.message or self.plans.progress,
            check=self.check,
            paused=self.paused and self.outcome == "running",
            partial=self.partial,
            priority=self.options.priority,
            claims=sorted(self.claiming.held()),
            waiting=self.waiting if self.outcome == "running" else "",
            **self.learning.makespan_fields(ended=self.outcome != "running"),
        )

    async def run_goal(self, goal: Goal) -> TaskFinished:
        """Plan and run until ``goal`` holds (or fails, is unsolvable or aborted)."""
        self.goal = str(goal)
        return await self._run(lambda: self._pursue(goal))

    async def run_file(self, task_file: TaskFile) -> TaskFinished:
        """Run a (verified) task file as written."""
        self.name = task_file.name
        return await self._run(lambda: self._follow(task_file))

    # ------------------------------------------------------------------ the task

    async def _run(self, body: Callable[[], Awaitable[tuple[TaskOutcome, str]]]) -> TaskFinished:
        self.started_at = time.time()
        self.events.emit(TaskStarted, goal=self.goal, name=self.name)
        outcome: TaskOutcome = "failed"
        try:
            with self._scope:
                outcome, message = await body()
        except anyio.get_cancelled_exc_class():
            self.claiming.release()
            self._finish("aborted", "the task agent stopped")
            raise
        except Exception as e:  # a bug must not leave the task "running" forever
            _log.exception("task %s failed unexpectedly", self.task_id)
            message = f"internal error: {type(e).__name__}: {e}"
        if self._scope.cancelled_caught:
            outcome, message = "aborted", self._abort_reason
        if outcome in ("partial", "failed", "aborted"):
            await self._safe_state()
        self.claiming.release()
        with anyio.CancelScope(shield=True), anyio.move_on_after(self.wm_timeout):
            await self.learning.save()
        return self._finish(outcome, message)

    async def _safe_state(self) -> None:
        """The safe-state phase (:mod:`._safe_state`): the task's robots put down what they
        hold. Never fails the task's ending; an abort during it (of a task that was not
        aborted already) stops it, its runs preempted."""
        self._scope = anyio.CancelScope()
        try:
            with self._scope:
                await self.safe_state.run(self.steps.used)
        except Exception:
            _log.exception("task %s: the safe-state phase failed", self.task_id)
        if self._scope.cancelled_caught:
            _log.warning("task %s: safe-state phase stopped: %s", self.task_id, self._abort_reason)

    def _finish(self, outcome: TaskOutcome, message: str) -> TaskFinished:
        self.outcome, self.finished_at = outcome, time.time()
        if self.reasons:
            listed = "; ".join(f"{i + 1}. {r}" for i, r in enumerate(self.reasons))
            message += f" [{self.replans} replan{'s' * (self.replans > 1)}: {listed}]"
        self.message = message
        return self.events.emit(
            TaskFinished,
            outcome=outcome,
            message=message,
            steps_run=self.steps.steps_run,
            replans=self.replans,
            duration=self.finished_at - self.started_at,
            check=self.check,
            partial=self.partial,
            **self.learning.makespan_fields(ended=True),
        )

    async def _pursue(self, goal: Goal) -> tuple[TaskOutcome, str]:
        if self.planner is None:
            return "failed", "this executor has no planner: it can only run task files"
        excluded: set[tuple[str, str]] = set()
        attempt = 0
        target = goal
        """What is pursued: the goal, or what of it is still reachable after a lost agent."""
        lost: list[LostFact] = []
        salvaged = -1
        while True:
            try:
                steps = await self.plans.plan(target, attempt, excluded)
                while await self.claiming.claim(steps, preemptible=True):
                    steps = await self.plans.plan(target, attempt, excluded)  # changed meanwhile
            except (UnsolvableError, DomainError) as e:
                if attempt == 0:
                    return "unsolvable", str(e)
                if not self.steps.lost or salvaged == attempt:
                    if self.learning.lessons.failed:
                        return "failed", self.learning.nothing_left(unmet_goal(goal, self.wm))
                    return "failed", f"replanning found no plan: {e}"
                salvaged = attempt
                reachable, lost = await self._salvage(goal, str(e))
                if reachable is None:
                    return self._partial(goal, lost)
                target = reachable
                continue
            except PlanningError as e:
                return "failed", f"planning failed: {e}"
            failure = await self.claiming.run(steps)
            if self.steps.gave_way:
                await self.claiming.give_way()
                continue
            if failure is None:
                await self._catch_up()
                unmet = unmet_goal(target, self.wm)
                if not unmet:
                    if lost:
                        return self._partial(goal, lost)
                    await self._verify(goal)
                    return "succeeded", f"the goal holds: {self.steps.steps_run} steps run"
                reason = f"the plan ran but the goal does not hold: {'; '.join(unmet)}"
            else:
                reason = str(failure)
                outage = await self._outage_during(failure)  # a lost router teaches nothing
                learned = None if outage else await self._learn(failure)
                if learned is not None:
                    reason = f"{reason}; the next plan avoids this step"
                if failure.reason in EXCLUDED_REASONS and not outage:
                    excluded.add((failure.agent, failure.skill))
            if attempt >= self.options.max_replans:
                if lost or self.steps.lost:
                    self.partial = self._partial_result(goal, lost)
                return "failed", f"{reason} (no replan left of {self.options.max_replans})"
            attempt += 1
            self.reasons.append(reason)
            self.events.emit(Replanning, attempt=attempt, reason=reason)

    # ------------------------------------------------------------------ degraded

    async def _salvage(self, goal: Goal, why: str) -> tuple[Goal | None, list[LostFact]]:
        """After a lost agent left the goal unreachable: the facts the agents left can still
        reach together, and the facts lost with why (:mod:`._salvage`). None: nothing is left
        to do."""
        assert self.planner is not None
        gone = ", ".join(sorted(self.steps.lost))
        keep, todo, lost = await still_reachable(
            self.planner, self.plans.agents(set()), self.wm, goal, why=why, gone=gone
        )
        _log.warning(
            "task %s: %s lost; %d goal facts still reachable, %d lost",
            self.task_id,
            gone,
            todo,
            len(lost),
        )
        self.reasons.append(
            f"{gone} lost: the goal is unreachable without it; pursuing the "
            f"{len(keep)} of {len(goal.literals)} goal facts still reachable"
        )
        self.events.emit(Replanning, attempt=len(self.reasons), reason=self.reasons[-1])
        return (Goal(literals=tuple(keep)) if todo else None), lost

    def _partial_result(self, goal: Goal, lost: list[LostFact]) -> PartialResult:
        return partial_result(goal, lost, self.wm, self.steps.lost.values())

    def _partial(self, goal: Goal, lost: list[LostFact]) -> tuple[TaskOutcome, str]:
        self.partial = self._partial_result(goal, lost)
        return partial_ending(goal, self.partial)

    async def _outage_during(self, failure: StepOutcome) -> bool:
        """Whether a lost router or a partition overlapped the failed step (its failure is
        then no reason to leave the skill out): waits for the vanished tokens to be judged."""
        await anyio.sleep(self.discovery.settle)
        await self.plans.await_agents()
        return self.discovery.outages > failure.outages

    async def _learn(self, failure: StepOutcome) -> FailedStep | None:
        """The learning hook for a failed step: kept with the state it failed in."""
        await self._catch_up()
        agents = self.discovery.agents(include_unavailable=True)
        return self.learning.failed(
            failure, next((a for a in agents if a.name == failure.agent), None)
        )

    async def _follow(self, task_file: TaskFile) -> tuple[TaskOutcome, str]:
        durations = {
            s.name: s.duration
            for a in self.discovery.agents(include_unavailable=True)
            for s in a.skills
        }
        steps = self.plans.number(schedule(steps_from_file(task_file), durations))
        self.events.emit(
            Planned,
            steps=[s.planned() for s in steps],
            names=self.plans.names(steps),
            planner="task file",
            makespan=max((s.finish for s in steps), default=0.0),
            sequential=sum(s.finish - s.start for s in steps),
        )
        await self.claiming.claim(steps)  # a task file cannot plan again: never preempted
        failure: StepOutcome | None = await self.steps.run(steps)
        if failure is not None:
            return "failed", str(failure)
        return "succeeded", f"every step succeeded: {self.steps.steps_run} steps run"

    async def _verify(self, goal: Goal) -> None:
        """Check each goal fact (``verify``); a failing check is logged, never fails the task."""
        if self.verify is None:
            return
        try:
            self.check = await self.verify(goal)
        except Exception:
            _log.exception("task %s: the goal check failed", self.task_id)

    async def _catch_up(self) -> None:
        """Wait until the replica shows the effects of every finished step."""
        try:
            await self.wm.wait_for_revision(self.steps.effects_revision, timeout=self.wm_timeout)
        except TimeoutError:
            _log.warning(
                "task %s: the world model did not reach revision %d within %g s",
                self.task_id,
                self.steps.effects_revision,
                self.wm_timeout,
            )


def _observed(
    publish: Callable[[TaskEvent], None], learning: TaskLearning
) -> Callable[[TaskEvent], None]:
    """``publish``, after ``learning`` saw the event (run times, makespans)."""

    def both(event: TaskEvent) -> None:
        learning.observe(event)
        publish(event)

    return both
