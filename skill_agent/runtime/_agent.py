"""The skill agent's runtime core: :class:`AgentCore` hosts the runs of one agent (no Zenoh).

The transport (``skill_agent.server``) turns requests into calls on this class and publishes
what :meth:`AgentCore.subscribe` delivers. Everything is one task group: :meth:`AgentCore.run`
hosts it; every run is a task in it; cancelling ``run`` preempts every active run (its
``on_preempt`` runs) before ``run`` returns.

``start`` refuses, before anything moves, with: :class:`UnknownSkillError` (with the closest
name), the :class:`ParameterError` family (from ``specify``), :class:`ResourceBusyError` (the
device and the run holding it) and :class:`PreconditionError` (the reason). With
``StartRun.queue`` a start on busy devices is accepted at once and waits in FIFO order; its
pre-conditions are checked when its turn comes (a false one ends it with reason
``precondition``). Every accepted run emits progress events and exactly one result.
"""

from __future__ import annotations

import difflib
import functools
import logging
import re
import uuid
from collections import deque
from collections.abc import Callable, Mapping
from typing import Any

import anyio
import msgspec
from anyio.abc import TaskGroup, TaskStatus

from skill_agent._composite import CompositeSkill, Node, check_composite
from skill_agent._errors import (
    ParameterError,
    RunStateError,
    SkillError,
    SkillLoadError,
    UnknownRunError,
    UnknownSkillError,
)
from skill_agent._skill import Skill
from skill_agent.conditions._model import ConditionRegistry
from skill_agent.parameters._bindings import with_bindings
from skill_agent.parameters._specify import Specified, specify
from skill_agent.protocol._log import (
    ProgressEntry,
    RefusedEntry,
    ResultEntry,
    RunStartedEntry,
    WmWriteEntry,
)
from skill_agent.protocol._runs import RunEvent, RunInfo, RunResult, RunStarted, StartRun
from skill_agent.protocol._skills import SkillDescription
from skill_agent.runtime._control import RunEnv
from skill_agent.runtime._event_log import EventLog
from skill_agent.runtime._locks import ResourceLocks
from skill_agent.runtime._run import Run
from skill_agent.runtime._simulated import SimulatedOutcomes
from wm_store import WmClient, display_name
from wm_store.protocol import Value

__all__ = ["AgentCore", "SkillEntry"]

_log = logging.getLogger(__name__)
_RUN_ID = re.compile(r"[A-Za-z0-9_-][A-Za-z0-9_.-]{0,127}")


class SkillEntry(msgspec.Struct, frozen=True):
    """A loaded skill: its description, a factory making one implementation per run, and
    where it came from (entry point or dotted path)."""

    description: SkillDescription
    factory: Callable[[], Skill]
    source: str = ""


def _closest(name: str, names: list[str]) -> str:
    match = difflib.get_close_matches(name, names, n=1, cutoff=0.5)
    return f"; did you mean {match[0]!r}?" if match else ""


def _tree(factory: Callable[[], Skill]) -> Node | None:
    """The tree of a composite skill's factory: the class, or a functools.partial of it."""
    cls = factory.func if isinstance(factory, functools.partial) else factory
    return cls.tree if isinstance(cls, type) and issubclass(cls, CompositeSkill) else None


def _natural(text: str) -> list[Any]:
    return [int(t) if t.isdigit() else t for t in re.split(r"(\d+)", text)]


class AgentCore:
    """Hosts the runs of one agent. Call :meth:`run` (in a task group) before ``start``."""

    def __init__(
        self,
        *,
        name: str,
        wm: WmClient,
        skills: Mapping[str, SkillEntry],
        devices: Mapping[str, object] | None = None,
        hardware: Mapping[str, str] | None = None,
        robot: str | None = None,
        events: EventLog | None = None,
        simulated: SimulatedOutcomes | None = None,
        preempt_timeout: float = 5.0,
        registry: ConditionRegistry | None = None,
        keep_finished: int = 256,
    ) -> None:
        """``devices``: device element id -> driver. ``hardware``: more devices this agent
        offers to hardware parameters, passed to ``params.specify`` (a key equal to a parameter
        name binds that parameter; other keys are free). The agent's devices are the
        ``devices`` keys, the ``hardware`` values and the ``hasA`` parts of ``robot``; a
        hardware parameter left out takes the first that fits, by id. ``simulated``: every
        run in simulated-outcome mode. Raises SkillLoadError for a composite that does not
        check."""
        self.name = name
        self.wm = wm
        self.devices = dict(devices or {})
        self.hardware = dict(hardware or {})
        self.robot = robot
        self.events = events if events is not None else EventLog()
        self.simulated = simulated
        self.preempt_timeout = preempt_timeout
        self.registry = registry
        self._skills: dict[str, SkillEntry] = {}
        self.replace_skills(skills)
        self._runs: dict[str, Run] = {}
        self._started: dict[str, RunStarted] = {}
        self._catalogs: dict[str, Mapping[str, SkillEntry]] = {}
        self._finished: deque[str] = deque()
        self._keep_finished = keep_finished
        self._children: dict[str, int] = {}
        self._subscribers: list[Callable[[RunEvent], None]] = []
        self._tg: TaskGroup | None = None
        self._default_outcomes = SimulatedOutcomes()
        self.env = RunEnv(
            agent=name,
            wm=wm,
            emit=self._emit,
            devices=self.devices,
            registry=registry,
            preempt_timeout=preempt_timeout,
            on_write=self._written,
            run_child=self._run_child,
        )
        self.locks = ResourceLocks(
            name=lambda device: display_name(wm.find_element(device), device)
        )

    # ------------------------------------------------------------------ hosting

    async def run(self, *, task_status: TaskStatus[None] = anyio.TASK_STATUS_IGNORED) -> None:
        """Host the runs until cancelled (blocks). ``started`` once ``start`` is possible.
        On cancellation every active run is preempted (on_preempt, result) before this
        returns. Raises RunStateError if already running."""
        if self._tg is not None:
            raise RunStateError(f"agent core {self.name} is already running")
        try:
            async with anyio.create_task_group() as tg:
                self._tg = tg
                task_status.started()
                await anyio.sleep_forever()
        finally:
            self._tg = None
            for run in list(self._runs.values()):  # a safety net: every run gets a result
                run.abandon("the agent stopped before the run began")
                self.locks.release(run.run_id)

    async def start(self, req: StartRun) -> RunStarted:
        """Start a run. Blocks through ``pre_sense`` and the pre-condition check (a queued
        run: only until queued); the run then goes on in the background. Raises
        UnknownSkillError, ParameterError (and subclasses), ResourceBusyError,
        PreconditionError, SkillLoadError (the factory failed), RunStateError (not running,
        or the run id is used by another skill). Retrying a run id returns the first answer."""
        if self._tg is None:
            raise RunStateError(f"agent core {self.name} is not running (call AgentCore.run)")
        if req.run_id in self._runs:
            return await self._retried(req)
        try:
            entry = self._entry(req.skill, self._skills)
            run_id = self._new_run_id(req.run_id)
            specified = self._specify(entry.description, req.params)
            resources = self._resources(entry.description, specified.values)
            skill = self._instantiate(entry)
            if req.queue:
                request = self.locks.enqueue(run_id, resources)  # our place in line, now
                queued = not request.granted
            else:
                self.locks.try_acquire(run_id, resources)
                queued = False
        except SkillError as exc:
            self._refused(req.skill, exc, req.run_id)
            raise

        run = Run(
            self.env,
            run_id=run_id,
            skill=skill,
            description=entry.description,
            params=specified.values,
            resources=resources,
            timeout=req.timeout,
            outcomes=self._outcomes(req.simulate),
            acquire=request.wait if queued else None,
        )
        started = RunStarted(run_id=run_id, params=run.params, inferred=dict(specified.inferred))
        self._register(run, specified, started, queued, self._skills)
        self._tg.start_soon(self._host, run, name=f"skill run {run_id}")
        if queued:
            return started
        return await self._accepted(run, started)

    async def stop(self, run_id: str) -> RunResult:
        """Stop a run and return its result once it ended (after on_preempt). An ended run's
        result is returned as is. Raises UnknownRunError."""
        run = self._run(run_id)
        run.stop("preempted", "stopped on request")
        return await run.wait()

    async def pause(self, run_id: str) -> None:
        """Hold the run at its next checkpoint and pause its devices; returns once they are
        at rest (see ``Run``), reported by a progress event naming them. Raises
        UnknownRunError, RunStateError."""
        run = self._run(run_id)
        run.pause()
        if run.acquired and not run.simulated:  # a queued run's devices are another's
            held = await run.devices.pause()
            if held and run.state == "paused":
                run.progress(f"held at rest: {', '.join(held)}")

    async def resume(self, run_id: str) -> None:
        """Release a paused run and resume its devices. Raises UnknownRunError,
        RunStateError."""
        run = self._run(run_id)
        run.resume()
        await run.devices.resume()

    def status(self, run_id: str) -> RunInfo:
        """A snapshot of the run (``paused`` while paused). Never blocks; raises
        UnknownRunError (ended runs are kept, the last ``keep_finished`` of them)."""
        return self._run(run_id).info()

    def runs(self, *, active_only: bool = True) -> list[RunInfo]:
        """Snapshots of the runs (sub-runs included, as ``<parent>.<n>``). Never blocks."""
        return [r.info() for r in self._runs.values() if not (active_only and r.done)]

    async def wait(self, run_id: str) -> RunResult:
        """Block until the run ended; returns its result. Raises UnknownRunError."""
        return await self._run(run_id).wait()

    def descriptions(self) -> list[SkillDescription]:
        """The descriptions of the current catalog, each hardware parameter this agent binds
        (``hardware[name]``) defaulting to its device (:func:`~skill_agent.parameters.
        with_bindings`: what the agent registers, so plans bind the devices runs lock).
        Never blocks."""
        return [with_bindings(entry.description, self.hardware) for entry in self._skills.values()]

    def replace_skills(self, skills: Mapping[str, SkillEntry]) -> None:
        """Swap the skill catalog (reload): new runs use the new entries, running runs (and
        their sub-runs) keep the code they started with. Raises SkillLoadError (the old
        catalog stays) if a composite does not check against the new catalog (composites are
        entries whose factory is a CompositeSkill class or a functools.partial of one)."""
        catalog = dict(skills)
        descriptions = {n: e.description for n, e in catalog.items()}
        trees = {n: t for n, e in catalog.items() if (t := _tree(e.factory)) is not None}
        for skill_name, tree in trees.items():
            check_composite(
                tree, descriptions[skill_name], descriptions, self.wm.ontology, trees=trees
            )
        self._skills = catalog

    def subscribe(self, callback: Callable[[RunEvent], None]) -> Callable[[], None]:
        """Call ``callback(event)`` for every progress event and result of every run (sub-runs
        included), in order, on the event loop; it must be quick. Returns the unsubscribe
        function."""
        self._subscribers.append(callback)

        def unsubscribe() -> None:
            if callback in self._subscribers:
                self._subscribers.remove(callback)

        return unsubscribe

    # ------------------------------------------------------------------ internals: starting

    def _entry(self, name: str, catalog: Mapping[str, SkillEntry]) -> SkillEntry:
        entry = catalog.get(name)
        if entry is None:
            names = sorted(catalog)
            raise UnknownSkillError(
                f"no skill {name!r} on agent {self.name}{_closest(name, names)}"
                f" (skills: {', '.join(names) or 'none'})"
            )
        return entry

    def _new_run_id(self, wanted: str) -> str:
        if not wanted:
            return uuid.uuid4().hex[:16]
        if not _RUN_ID.fullmatch(wanted):
            raise ParameterError(f"run id {wanted!r}: use 1-128 of [A-Za-z0-9_.-]")
        return wanted

    def _specify(self, desc: SkillDescription, given: Mapping[str, Value]) -> Specified:
        offered = {**{device: device for device in self.devices}, **self.hardware}
        return specify(
            desc, given, self.wm, hardware=offered, robot=self.robot, registry=self.registry
        )

    @staticmethod
    def _resources(desc: SkillDescription, values: Mapping[str, Value]) -> list[str]:
        hardware = (values.get(p.name) for p in desc.parameters if p.kind == "hardware")
        return sorted({v for v in hardware if isinstance(v, str) and v}, key=_natural)

    @staticmethod
    def _instantiate(entry: SkillEntry) -> Skill:
        try:
            return entry.factory()
        except Exception as exc:
            raise SkillLoadError(
                f"cannot create {entry.description.name} ({entry.source}): {exc}"
            ) from exc

    def _outcomes(self, simulate: bool) -> SimulatedOutcomes | None:
        if self.simulated is not None:
            return self.simulated
        return self._default_outcomes if simulate else None

    def _register(
        self,
        run: Run,
        specified: Specified,
        started: RunStarted,
        queued: bool,
        catalog: Mapping[str, SkillEntry],
    ) -> None:
        self._runs[run.run_id] = run
        self._started[run.run_id] = started
        self._catalogs[run.run_id] = catalog
        self.events.record(
            RunStartedEntry(
                agent=self.name,
                run_id=run.run_id,
                skill=run.description.name,
                params=dict(run.params),
                inferred=dict(specified.inferred),
                resources=list(run.resources),
                simulated=run.simulated,
                queued=queued,
                parent=run.parent.run_id if run.parent is not None else "",
            )
        )

    async def _accepted(self, run: Run, started: RunStarted) -> RunStarted:
        await run.wait_accepted()
        if run.refusal is not None:
            self._refused(run.description.name, run.refusal, run.run_id)
            raise run.refusal
        return started

    async def _retried(self, req: StartRun) -> RunStarted:
        run = self._runs[req.run_id]
        if run.description.name != req.skill:
            raise RunStateError(f"run id {req.run_id} is taken by a run of {run.description.name}")
        return await self._accepted(run, self._started[req.run_id])

    def _refused(self, skill: str, exc: SkillError, run_id: str = "") -> None:
        self.events.record(
            RefusedEntry(
                agent=self.name, skill=skill, code=exc.code, message=str(exc), run_id=run_id
            )
        )

    async def _host(self, run: Run) -> None:
        try:
            await run.drive()
        finally:
            self.locks.release(run.run_id)

    # ------------------------------------------------------------------ internals: sub-runs

    async def _run_child(self, parent: Run, skill: str, params: Mapping[str, Value]) -> RunResult:
        root = parent
        ancestors = [parent.run_id]
        while root.parent is not None:
            root = root.parent
            ancestors.append(root.run_id)
        catalog = self._catalogs.get(root.run_id, self._skills)
        entry = self._entry(skill, catalog)
        specified = self._specify(entry.description, params)
        resources = self._resources(entry.description, specified.values)
        number = self._children[parent.run_id] = self._children.get(parent.run_id, 0) + 1
        run_id = f"{parent.run_id}.{number}"
        self.locks.try_acquire(run_id, resources, borrow_from=ancestors)
        try:
            run = Run(
                self.env,
                run_id=run_id,
                skill=self._instantiate(entry),
                description=entry.description,
                params=specified.values,
                resources=resources,
                outcomes=parent.outcomes,
                parent=parent,
            )
            started = RunStarted(run_id=run_id, params=run.params, inferred=specified.inferred)
            self._register(run, specified, started, False, catalog)
            return await run.drive()
        finally:
            self.locks.release(run_id)

    # ------------------------------------------------------------------ internals: events

    def _run(self, run_id: str) -> Run:
        run = self._runs.get(run_id)
        if run is None:
            raise UnknownRunError(f"no run {run_id!r} on agent {self.name}")
        return run

    def _emit(self, event: RunEvent) -> None:
        if isinstance(event, RunResult):
            self.events.record(ResultEntry(result=event))
            self._ended(event.run_id)
        else:
            self.events.record(ProgressEntry(progress=event))
        for callback in list(self._subscribers):
            try:
                callback(event)
            except Exception:
                _log.exception("a run-event subscriber failed")

    def _written(self, entry: WmWriteEntry) -> None:
        self.events.record(entry)

    def _ended(self, run_id: str) -> None:
        self._catalogs.pop(run_id, None)
        self._children.pop(run_id, None)
        self._finished.append(run_id)
        while len(self._finished) > self._keep_finished:
            old = self._finished.popleft()
            self._runs.pop(old, None)
            self._started.pop(old, None)
