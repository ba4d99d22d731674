"""The task agent: :class:`TaskService` (requests -> replies, the task registry; no Zenoh) and
:func:`serve_tasks` (its Zenoh adapter, what ``skimesh task-agent`` runs).

Keys (prefix ``skimesh/<mesh>``): ``tasks/rpc`` answers one
:data:`~task_agent.protocol.TaskRequest` with one :data:`~task_agent.protocol.TaskReply`;
``tasks/<task>/events`` carries each task's events (congestion control BLOCK, ``seq`` 1, 2, ...).
A client that wants every event of its task subscribes first and submits with its own
``task_id``. The service follows every agent's event log (``agents/*/events``,
:class:`~task_agent.execution.RunWrites`), so each ``StepFinished`` lists the world-model
revisions its run wrote.

Requests:

- ``SubmitGoal``: the goal is parsed against the world model now (an unknown element or a
  syntax error is refused with code ``goal_parse``); planning and execution then run as a task
  of the service's task group, and the reply ``TaskAccepted`` comes at once. An unsolvable
  goal ends the task with outcome ``unsolvable`` and the planner's reason.
- ``SubmitFile``: loaded (``verification`` error for malformed TOML) and verified against the
  world model and the agents available now; a file with problems is refused with
  ``VerifyReply(ok=False, problems)``, else accepted like a goal. ``VerifyFile`` only verifies.
- ``TaskStatus`` / ``ListTasks`` from the registry (the last ``keep_finished`` ended tasks are
  kept); ``AbortTask`` stops every run of the task and answers once it ended (or after
  ``abort_wait`` seconds).
- ``TaskHistory``: the task's kept events after a ``seq`` (``HistoryReply``; each task keeps
  at most ``max_events`` events, progress dropped first: :class:`~task_agent.execution.
  EventHistory`), for a watcher that comes late (``skimesh task watch``).
- ``PauseTask`` / ``ResumeTask``: hold the task (no new step starts, its runs are paused on
  their agents) and release it (:meth:`~task_agent.execution.Executor.pause`); refused with
  ``task_ended`` once the task has ended, answered ``OkReply`` saying so when the task is held
  already (or not held).

Refusals are error replies carrying ``ErrorReply{code, message}`` (:mod:`meshlink.rpc`, which
decodes, dispatches and encodes): the standard ``bad_request`` (malformed bytes of any kind, a
task id that is no key segment, operator fallback for a skill no registered agent offers),
``too_large`` (a request over ``max_request_bytes``) and ``internal``, and the service's
``task_exists``, ``unknown_task``, ``goal_parse``, ``verification``. Nothing malformed crashes
the service or changes its state. Nothing blocks the loop: planning solves in a worker thread
(the planner's limiter).

A goal task that succeeded is checked fact by fact before it ends (``TaskFinished.check``,
``TaskInfo.check``): in the world model, and in the physics when a simulator answers on
``sim/truth`` (:func:`mesh_verifier`; the check says so when none does).
"""

from __future__ import annotations

import functools
import logging
import uuid
from collections import OrderedDict
from collections.abc import Awaitable, Callable
from pathlib import Path

import anyio
from anyio.abc import TaskGroup, TaskStatus

from device_drivers.truth import TruthClient
from meshlink import Mesh, MeshlinkError, check_name
from meshlink.rpc import (
    BAD_REQUEST,
    DEFAULT_MAX_REQUEST_BYTES,
    INTERNAL,
    ErrorReply,
    RequestHandler,
    coded_errors,
    encode,
)
from wm_store import WmClient

from ._errors import RequestError, TaskError, VerificationError
from ._goal_text import parse_goal
from ._goals import Goal, check_goal
from ._physics import NO_SIMULATOR, check_goal_facts
from .claims import ClaimBook
from .discovery import Discovery
from .execution import (
    MAX_TASK_EVENTS,
    Executor,
    GoalVerifier,
    PlanSource,
    RunWrites,
    SkillRunner,
    WorldModel,
    ZenohRunner,
)
from .learning import DurationBook
from .operator import serve_operator
from .protocol import (
    READ_REQUESTS,
    AbortTask,
    GoalCheck,
    HistoryReply,
    ListTasks,
    OkReply,
    PauseTask,
    ResumeTask,
    SubmitFile,
    SubmitGoal,
    TaskAccepted,
    TaskEvent,
    TaskFinished,
    TaskHistory,
    TaskInfo,
    TaskOptions,
    TaskReply,
    TaskRequest,
    TasksReply,
    VerifyFile,
    VerifyProblem,
    VerifyReply,
)
from .protocol import (
    TaskStatus as TaskStatusRequest,
)
from .taskfile import load_task_file
from .verification import verify

__all__ = ["TaskService", "mesh_verifier", "serve_tasks"]

_log = logging.getLogger(__name__)
PlannerFactory = Callable[[TaskOptions], PlanSource]
_task_errors = coded_errors(TaskError)


def _to_reply(exc: Exception) -> ErrorReply | None:
    """The service's refusals: a :class:`TaskError` answers its code; a ``ValueError`` (a task
    id that is no key segment) answers ``bad_request`` with its own text."""
    if isinstance(exc, ValueError):
        return ErrorReply(code=BAD_REQUEST, message=str(exc))
    return _task_errors(exc)


def default_planners() -> PlannerFactory:
    """One :class:`~task_agent.planning.Planner` per engine and time-out, sharing one limiter
    (one solve at a time)."""
    from .planning import Engine, Planner

    limiter = anyio.CapacityLimiter(1)

    @functools.cache
    def make(engine: str, timeout: float, planning: str) -> Planner:
        kind: Engine = "fast-downward" if engine == "fast-downward" else "kairos"
        decompose = planning != "monolithic"
        return Planner(engine=kind, timeout=timeout, decompose=decompose, limiter=limiter)

    return lambda options: make(options.engine, options.planner_timeout, options.planning)


def mesh_verifier(mesh: Mesh, wm: WorldModel, *, find_timeout: float = 2.0) -> GoalVerifier:
    """Checks a goal's facts in ``wm`` and, if a simulator answers on ``mesh`` within
    ``find_timeout`` s, in its physics (asked anew for every task: simulators come and go)."""

    async def verify(goal: Goal) -> GoalCheck:
        truth, why = await TruthClient.find(mesh, timeout=find_timeout)
        note = "" if truth is not None else f"{NO_SIMULATOR} ({why})"
        return await check_goal_facts(goal, wm, truth, note=note)

    return verify


async def _world_model_only(wm: WorldModel, goal: Goal) -> GoalCheck:
    return await check_goal_facts(goal, wm, None)


class TaskService:
    """Runs tasks and answers requests about them (see the module doc). Start :meth:`run` in a
    task group before calling :meth:`handle`."""

    def __init__(
        self,
        *,
        wm: WorldModel,
        discovery: Discovery,
        runner: SkillRunner,
        publish: Callable[[TaskEvent], None],
        planners: PlannerFactory | None = None,
        operator_agent: str = "operator",
        keep_finished: int = 256,
        abort_wait: float = 10.0,
        writes: RunWrites | None = None,
        max_request_bytes: int = DEFAULT_MAX_REQUEST_BYTES,
        verify: GoalVerifier | None = None,
        max_events: int = MAX_TASK_EVENTS,
        durations: DurationBook | None = None,
        preemption: bool = True,
    ) -> None:
        self.wm = wm
        self.preemption = preemption
        """A task of higher priority may take a running task's claim at that task's next step
        boundary (tasks submitted ``TaskOptions.preemptible``; :mod:`task_agent.claims`)."""
        self.durations = durations or DurationBook()
        """Learned run times, shared by every task (:mod:`task_agent.learning`)."""
        self.max_events = max_events
        """Events kept per task (for ``TaskHistory``)."""
        self.verify = verify or functools.partial(_world_model_only, wm)
        """Checks a succeeded goal fact by fact (default: in the world model only)."""
        self.writes = writes
        """The agents' event logs (steps then report their world-model writes), if followed."""
        self.discovery = discovery
        self.runner = runner
        self.publish = publish
        self.planners = planners or default_planners()
        self.operator_agent = operator_agent
        self.keep_finished = keep_finished
        self.abort_wait = abort_wait
        self._tasks: OrderedDict[str, tuple[Executor, anyio.Event]] = OrderedDict()
        self.claims = ClaimBook()
        """What each running task holds: two tasks never command one robot or act on one
        object at once; a task that needs what another holds waits (priority first)."""
        self._tg: TaskGroup | None = None
        self.rpc: RequestHandler[TaskRequest, TaskReply] = RequestHandler(
            TaskRequest,
            self.handle,
            errors=_to_reply,
            max_request_bytes=max_request_bytes,
            name="tasks/rpc",
        )
        """``tasks/rpc``: bytes -> :meth:`handle` -> bytes (:meth:`RequestHandler.serve_on
        <meshlink.rpc.RequestHandler.serve_on>` serves it)."""
        self.query: RequestHandler[TaskRequest, TaskReply] = RequestHandler(
            TaskRequest,
            self._handle_read,
            errors=_to_reply,
            max_request_bytes=max_request_bytes,
            name="tasks/query",
        )
        """``tasks/query``: the read-only requests (:data:`READ_REQUESTS`); others refused."""

    async def run(self, *, task_status: TaskStatus[None] = anyio.TASK_STATUS_IGNORED) -> None:
        """Host the tasks until cancelled; cancelling aborts every running task (their runs
        are stopped) before this returns."""
        async with anyio.create_task_group() as tg:
            self._tg = tg
            try:
                task_status.started()
                await anyio.sleep_forever()
            finally:
                self._tg = None

    def tasks(self, *, active_only: bool = False) -> list[TaskInfo]:
        infos = [executor.info() for executor, _ in self._tasks.values()]
        return [i for i in infos if i.outcome == "running" or not active_only]

    # ------------------------------------------------------------------ requests

    async def handle_bytes(self, data: bytes) -> tuple[bytes, bool]:
        """Decode, dispatch, encode (:attr:`rpc`). Returns ``(payload, ok)``; never raises an
        Exception."""
        return await self.rpc.handle_bytes(data)

    async def handle(self, request: TaskRequest) -> TaskReply:
        """Answer one request; refusals raise :class:`TaskError` subclasses."""
        match request:
            case SubmitGoal(goal=goal, options=options, task_id=task_id):
                parsed = (
                    parse_goal(goal, self.wm)
                    if isinstance(goal, str)
                    else check_goal(goal, self.wm)
                )
                executor = self._new(task_id, options)
                self._start(executor, functools.partial(executor.run_goal, parsed))
                return TaskAccepted(task_id=executor.task_id)
            case SubmitFile(text=text, options=options, task_id=task_id):
                task_file = load_task_file(text, source="the submitted task file")
                problems = verify(task_file, self.wm, self.discovery.agents())
                if problems:
                    return VerifyReply(ok=False, problems=problems)
                executor = self._new(task_id, options)
                self._start(executor, functools.partial(executor.run_file, task_file))
                return TaskAccepted(task_id=executor.task_id)
            case VerifyFile(text=text):
                try:
                    task_file = load_task_file(text, source="the task file")
                except VerificationError as e:
                    problem = VerifyProblem(path="", kind="structure", message=str(e))
                    return VerifyReply(ok=False, problems=[problem])
                problems = verify(task_file, self.wm, self.discovery.agents())
                return VerifyReply(ok=not problems, problems=problems)
            case TaskStatusRequest(task_id=task_id):
                return TasksReply(tasks=[self._get(task_id)[0].info()])
            case ListTasks(active_only=active_only):
                return TasksReply(tasks=self.tasks(active_only=active_only))
            case AbortTask(task_id=task_id, reason=reason):
                return await self._abort(task_id, reason)
            case TaskHistory(task_id=task_id, after_seq=after, limit=limit):
                return self._history(task_id, after, limit)
            case PauseTask(task_id=task_id, reason=reason):
                return await self._pause(task_id, reason)
            case ResumeTask(task_id=task_id):
                return await self._resume(task_id)
        raise RequestError(BAD_REQUEST, f"unsupported request {type(request).__name__}")

    async def _handle_read(self, request: TaskRequest) -> TaskReply:
        if not isinstance(request, READ_REQUESTS):
            raise RequestError(
                "read_only",
                f"tasks/query is read-only: send {type(request).__name__} to tasks/rpc",
            )
        return await self.handle(request)

    # ------------------------------------------------------------------ registry

    def _new(self, task_id: str, options: TaskOptions) -> Executor:
        if self._tg is None:
            raise RequestError(INTERNAL, "the task service is not running")
        task_id = check_name(task_id, "task id") if task_id else f"t-{uuid.uuid4().hex[:10]}"
        if task_id in self._tasks:
            raise RequestError("task_exists", f"task {task_id!r} exists; choose another id")
        agents = self.discovery.agents(include_unavailable=True)
        offered = sorted({s.name for a in agents for s in a.skills})
        if unknown := ", ".join(sorted(options.operator_fallback_skills - set(offered))):
            why = f"no registered agent offers {unknown} (skills: {', '.join(offered) or 'none'})"
            raise RequestError(BAD_REQUEST, f"operator fallback: {why}")
        return Executor(
            task_id=task_id,
            wm=self.wm,
            discovery=self.discovery,
            runner=self.runner,
            publish=self.publish,
            writes=self.writes,
            options=options,
            planner=self.planners(options),
            operator_agent=self.operator_agent,
            verify=self.verify,
            max_events=self.max_events,
            claims=self.claims,
            durations=self.durations,
            preemption=self.preemption,
        )

    def _start(self, executor: Executor, body: Callable[[], Awaitable[TaskFinished]]) -> None:
        assert self._tg is not None
        done = anyio.Event()
        self._tasks[executor.task_id] = (executor, done)

        async def run() -> None:
            try:
                await body()
            finally:
                done.set()
                self._forget_old()

        self._tg.start_soon(run, name=f"task {executor.task_id}")

    def _forget_old(self) -> None:
        ended = [tid for tid, (ex, _) in self._tasks.items() if ex.outcome != "running"]
        for task_id in ended[: max(0, len(ended) - self.keep_finished)]:
            del self._tasks[task_id]

    def _get(self, task_id: str) -> tuple[Executor, anyio.Event]:
        found = self._tasks.get(task_id)
        if found is None:
            known = ", ".join(list(self._tasks)[-5:]) or "none"
            raise RequestError("unknown_task", f"no task {task_id!r} (latest: {known})")
        return found

    async def _abort(self, task_id: str, reason: str) -> OkReply:
        executor, done = self._get(task_id)
        if executor.outcome != "running":
            return OkReply(message=f"task {task_id} already ended: {executor.outcome}")
        executor.abort(reason or "aborted on request")
        with anyio.move_on_after(self.abort_wait):
            await done.wait()
        return OkReply(message=f"task {task_id}: {executor.outcome}")

    def _history(self, task_id: str, after: int, limit: int) -> HistoryReply:
        executor = self._get(task_id)[0]
        events = executor.history.since(after, limit + 1)
        return HistoryReply(
            task_id=task_id,
            events=events[:limit],
            outcome=executor.outcome,
            dropped=executor.history.dropped,
            more=len(events) > limit,
        )

    async def _pause(self, task_id: str, reason: str) -> OkReply:
        executor = self._get(task_id)[0]
        if executor.outcome != "running":
            raise RequestError("task_ended", f"task {task_id} has ended: {executor.outcome}")
        if not await executor.pause(reason or "paused on request"):
            return OkReply(message=f"task {task_id} is paused already")
        return OkReply(message=f"task {task_id} paused: no new step starts until resumed")

    async def _resume(self, task_id: str) -> OkReply:
        executor = self._get(task_id)[0]
        if executor.outcome != "running":
            raise RequestError("task_ended", f"task {task_id} has ended: {executor.outcome}")
        if not await executor.resume():
            return OkReply(message=f"task {task_id} is not paused")
        return OkReply(message=f"task {task_id} resumed")


async def serve_tasks(
    mesh: Mesh,
    wm: WmClient,
    *,
    planners: PlannerFactory | None = None,
    operator: str | None = "operator",
    grace: float = 15.0,
    durations: Path | str | None = None,
    preemption: bool = True,
    task_status: TaskStatus[None] = anyio.TASK_STATUS_IGNORED,
) -> None:
    """Serve the task agent on ``mesh`` until cancelled; with ``operator`` (a name), also the
    operator agent (:func:`~task_agent.operator.serve_operator`). ``started`` once
    ``tasks/rpc`` is reachable. Cancelling aborts every running task (runs stopped).
    ``grace``: seconds agents whose tokens vanished together (a lost router, a partition)
    stay unknown, their runs followed on, before they are lost (:class:`Discovery`).
    ``durations``: the file the learned run times are kept in (default: in memory).
    ``preemption``: a waiting task of higher priority may take what a running one holds at
    its next step boundary (:class:`TaskService`)."""
    keys = mesh.keys
    discovery = Discovery(wm, grace=grace)

    def reachable(agent: str) -> bool:
        return discovery.is_alive(agent) or discovery.is_unknown(agent)

    writes = RunWrites()

    def publish(event: TaskEvent) -> None:
        try:
            mesh.put(keys.task_events(event.task_id), encode(event))
        except MeshlinkError as e:
            _log.warning("could not publish an event of task %s: %s", event.task_id, e)

    service = TaskService(
        wm=wm,
        discovery=discovery,
        runner=ZenohRunner(mesh, alive=reachable, lost_grace=grace + 1.0),
        publish=publish,
        planners=planners,
        operator_agent=operator or "",
        writes=writes,
        verify=mesh_verifier(mesh, wm),
        durations=await anyio.to_thread.run_sync(DurationBook.load, durations),
        preemption=preemption,
    )

    async with anyio.create_task_group() as tg:
        await tg.start(discovery.watch, mesh)
        await tg.start(writes.follow, mesh)  # agents/*/events: each step's world-model writes
        if operator:
            await tg.start(
                functools.partial(serve_operator, mesh, wm, name=operator, discovery=discovery)
            )
        await tg.start(service.run)
        await tg.start(mesh.serve, keys.tasks_rpc(), service.rpc.serve_on(keys.tasks_rpc()))
        await tg.start(mesh.serve, keys.tasks_query(), service.query.serve_on(keys.tasks_query()))
        _log.info(
            "task agent ready on mesh %r: %d agents available (%s)%s",
            keys.mesh,
            len(discovery.agents()),
            ", ".join(a.name for a in discovery.agents()) or "none yet",
            f", operator agent {operator!r}" if operator else "",
        )
        task_status.started()
