"""A run as its agent sees and steers it: :class:`RunControl`, the base of
:class:`~skill_agent.runtime._run.Run`, and :class:`RunEnv`, what runs need from their agent.

:class:`RunControl` holds the run's state and answers for it: the status (``state``,
``info``), the commands from outside (``stop``, ``abandon``, ``pause``, ``resume``; sync, never
blocking), the waits (``wait``, ``wait_accepted``, ``checkpoint``) and the events reporting it,
each :class:`~skill_agent.protocol.Progress` with the next ``seq``, then exactly one
:class:`~skill_agent.protocol.RunResult`. Driving the lifecycle is :class:`Run`'s.

A pause holds the run at its checkpoints and stops its deadline (and its sub-runs'): the
time left is kept and counts again from the resume. Its devices are paused by the agent
through :attr:`RunControl.devices` (a :class:`~skill_agent.runtime._device_hold.DeviceHold`).
"""

from __future__ import annotations

import math
import time
from collections.abc import Awaitable, Callable, Mapping, Sequence
from dataclasses import dataclass, field
from typing import TYPE_CHECKING

import anyio
import anyio.lowlevel

from skill_agent._errors import PreconditionError, RunStateError
from skill_agent.conditions._model import ConditionRegistry
from skill_agent.parameters._states import param_states
from skill_agent.protocol._log import WmWriteEntry
from skill_agent.protocol._runs import (
    Progress,
    ResultReason,
    RunEvent,
    RunInfo,
    RunResult,
    RunState,
)
from skill_agent.protocol._skills import SkillDescription
from skill_agent.runtime._device_hold import DeviceHold
from wm_store import WmClient
from wm_store.protocol import Value

if TYPE_CHECKING:
    from skill_agent.runtime._run import Run

__all__ = ["ChildRunner", "RunControl", "RunEnv"]

ChildRunner = Callable[["Run", str, Mapping[str, Value]], Awaitable[RunResult]]
"""``(parent, skill, params) -> result``: runs a sub-run inside the parent's task."""

_FINAL: dict[ResultReason, RunState] = {"ok": "succeeded", "preempted": "preempted"}


@dataclass(frozen=True)
class RunEnv:
    """What runs need from their agent (one per agent; built by ``AgentCore``)."""

    agent: str
    wm: WmClient
    emit: Callable[[RunEvent], None]
    devices: Mapping[str, object] = field(default_factory=dict)
    registry: ConditionRegistry | None = None
    preempt_timeout: float = 5.0
    on_write: Callable[[WmWriteEntry], None] | None = None
    """Called with every world-model transaction a run committed (its effects, and every
    write its skill made through ``ctx.wm`` or ``ctx.transact``); quick, on the loop."""
    run_child: ChildRunner | None = None


class RunControl:
    """A run's state, its commands, waits and events (see the module docstring)."""

    def __init__(
        self,
        env: RunEnv,
        *,
        run_id: str,
        description: SkillDescription,
        params: Mapping[str, Value],
        resources: Sequence[str] = (),
        parent: RunControl | None = None,
    ) -> None:
        self.env, self.run_id, self.description = env, run_id, description
        self.params = dict(params)
        self.resources = list(resources)
        self.parent = parent
        self.children: list[RunControl] = []
        if parent is not None:
            parent.children.append(self)
        self.devices = DeviceHold(run_id, env.devices, self.resources)
        """The run's pausable devices (paused and resumed by the agent with the run)."""
        self.started_at = time.time()
        self._state: RunState = "pending"
        self._step = ""
        self._seq = 0
        self._scope = anyio.CancelScope()
        self._stop: tuple[ResultReason, str] | None = None
        self._resumed: anyio.Event | None = None
        self._time_left: float | None = None  # of the deadline, while paused
        self._trusted: list[str] = []
        self._effects_revision = 0
        self._accepted = anyio.Event()
        self._done = anyio.Event()
        self.refusal: PreconditionError | None = None
        self.result: RunResult | None = None

    # ------------------------------------------------------------------ status

    @property
    def state(self) -> RunState:
        return "paused" if self._resumed is not None and self.result is None else self._state

    @property
    def done(self) -> bool:
        return self.result is not None

    def info(self) -> RunInfo:
        return RunInfo(
            run_id=self.run_id,
            skill=self.description.name,
            state=self.state,
            params=dict(self.params),
            resources=list(self.resources),
            started_at=self.started_at,
            result=self.result,
            param_states=param_states(self.description, self.params),
        )

    async def wait(self) -> RunResult:
        """Block until the run has ended; returns its result."""
        await self._done.wait()
        assert self.result is not None
        return self.result

    async def wait_accepted(self) -> None:
        """Block until the pre-conditions passed, or the run ended (then see ``refusal``)."""
        await self._accepted.wait()

    # ------------------------------------------------------------------ commands (sync)

    def stop(self, reason: ResultReason = "preempted", message: str = "stopped") -> None:
        """Cancel the run (it ends at the skill's next await; a paused run is released);
        idempotent, never blocks."""
        if self.result is None:
            self._stop = self._stop or (reason, message)
            self._scope.cancel()
            if self._resumed is not None:  # no checkpoint holds on_preempt
                resumed, self._resumed = self._resumed, None
                resumed.set()

    def abandon(self, message: str) -> None:
        """End a run whose task is gone without driving it (result ``preempted``)."""
        if self.result is None:
            self._finish("preempted", message)

    def pause(self) -> None:
        """Hold at the next checkpoint; the deadlines of the run and its sub-runs stop (see
        the module doc). Raises RunStateError if ended, being stopped or already paused."""
        if self.result is not None or self._resumed is not None:
            raise RunStateError(f"run {self.run_id} is {self.state}; it cannot be paused")
        if self._stop is not None:  # on_preempt must reach its devices
            raise RunStateError(f"run {self.run_id} is being stopped; it cannot be paused")
        self._resumed = anyio.Event()
        now = anyio.current_time()
        for run in self._family():
            run._freeze_deadline(now)
        self._emit_progress("paused", "paused; holds at its next checkpoint")

    def resume(self) -> None:
        """Release a paused run; its deadlines count again. Raises RunStateError if it is
        not paused."""
        if self.result is not None or self._resumed is None:
            raise RunStateError(f"run {self.run_id} is {self.state}, not paused")
        resumed, self._resumed = self._resumed, None
        now = anyio.current_time()
        for run in self._family():
            if run._time_left is not None and not run.held:
                run._scope.deadline, run._time_left = now + run._time_left, None
        resumed.set()
        self._emit_progress(self._state, "resumed")

    @property
    def held(self) -> bool:
        """Paused, itself or through a parent."""
        run: RunControl | None = self
        while run is not None:
            if run._resumed is not None and run.result is None:
                return True
            run = run.parent
        return False

    def set_deadline(self, seconds: float) -> None:
        """The run's deadline, ``seconds`` from now (kept, not counting, while held)."""
        if self.held:
            self._time_left = seconds
        else:
            self._scope.deadline = anyio.current_time() + seconds

    def _freeze_deadline(self, now: float) -> None:
        deadline = self._scope.deadline
        if self._time_left is None and not math.isinf(deadline):
            self._time_left = max(0.0, deadline - now)
            self._scope.deadline = math.inf

    def _family(self) -> list[RunControl]:
        """This run and its sub-runs that have not ended, at any depth."""
        found: list[RunControl] = []
        stack: list[RunControl] = [self]
        while stack:
            run = stack.pop()
            if run.result is None:
                found.append(run)
                stack.extend(run.children)
        return found

    async def checkpoint(self) -> None:
        await anyio.lowlevel.checkpoint()
        run: RunControl | None = self
        while run is not None:
            if run._resumed is not None:
                await run._resumed.wait()
                run = self  # re-check the whole chain after waking
            else:
                run = run.parent

    def progress(self, message: str, *, fraction: float = -1.0, step: str = "") -> None:
        self._emit_progress(self.state, message, fraction=fraction, step=step or self._step)

    def _emit_progress(
        self, state: RunState, message: str, *, fraction: float = -1.0, step: str = ""
    ) -> None:
        event = Progress(
            run_id=self.run_id,
            agent=self.env.agent,
            skill=self.description.name,
            seq=self._next_seq(),
            state=state,
            step=step or self._step,
            message=message,
            fraction=fraction,
            stamp=time.time(),
        )
        self.env.emit(event)

    def _next_seq(self) -> int:
        self._seq += 1
        return self._seq

    def _finish(self, reason: ResultReason, message: str) -> RunResult:
        self._state = _FINAL.get(reason, "failed")
        self._resumed = None
        self.result = RunResult(
            run_id=self.run_id,
            agent=self.env.agent,
            skill=self.description.name,
            seq=self._next_seq(),
            success=reason == "ok",
            reason=reason,
            message=message,
            params=dict(self.params),
            started_at=self.started_at,
            finished_at=time.time(),
            effects_revision=self._effects_revision,
            trusted_wm=list(self._trusted),
        )
        self.env.emit(self.result)
        self._accepted.set()
        self._done.set()
        return self.result
