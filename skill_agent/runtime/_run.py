"""One run of a skill: :class:`Run` drives the lifecycle, :class:`RunContext` is what the skill
sees.

Lifecycle (each step emits a :class:`~skill_agent.protocol.Progress` with the next ``seq``; the
run ends with exactly one :class:`~skill_agent.protocol.RunResult`)::

    pending (queued for devices) -> pre_sense -> checking_pre -> executing -> post_sense
        -> checking_post -> committing -> succeeded | failed | preempted

- *Sensing* is skipped, and the step named in ``RunResult.trusted_wm``, when every element in
  ``Skill.senses`` was updated less than ``description.sensing_max_age`` seconds ago.
- *Pre-conditions* false: reason ``precondition``; nothing executed. Until they pass the run is
  not *accepted* (:meth:`Run.wait_accepted`), so the agent can refuse the start with
  :class:`~skill_agent.PreconditionError`.
- *Execute* runs with the hold-conditions watched through ``wm.on_change`` (no polling); one
  turning false cancels the run: ``hold_violated``.
- *Post-conditions*: one that holds is fine; one that is false but has effects (a relation, a
  property value) is the skill's prediction and is committed; one that is false with no
  effect fails the run: ``postcondition``. Effects go in ONE transaction
  (``RunResult.effects_revision``), shielded from cancellation.
- *Stop*, *timeout* (a deadline on the run's cancel scope) and *hold violation* all cancel the
  run's scope: the skill gets ``Cancelled`` at its next ``await``; then ``on_preempt`` runs
  shielded, limited to ``preempt_timeout`` seconds. An unexpected exception in skill code ends
  the run with reason ``error`` (the exception text) and also calls ``on_preempt``; a
  :class:`~skill_agent.SkillFailure` ends it with ``execution`` (the skill cleaned up).
- *Timeout*: ``StartRun.timeout``, else ``description.timeout``, counted from when the run
  holds its devices (a queued run's wait does not count).
- *Pause* holds the run at its next checkpoint (between steps, and wherever the skill awaits
  :meth:`RunContext.checkpoint`); the deadline keeps running while paused.
- *Simulated outcome*: no sensing, no execute (composite skills do run their children,
  simulated); success is drawn, effects committed on success; failure is ``execution``.
- *World-model writes*: the skill's ``ctx.wm`` is a :class:`~skill_agent.runtime.RunWm`; every
  transaction committed through it (any write method, ``ctx.transact``, the effects) reaches
  ``RunEnv.on_write`` as a :class:`~skill_agent.protocol.WmWriteEntry` naming the run's step
  (``preempt`` for ``on_preempt``).
"""

from __future__ import annotations

import logging
import time
from collections.abc import Awaitable, Callable, Iterator, Mapping, Sequence
from contextlib import contextmanager
from dataclasses import dataclass, field
from typing import TypeVar

import anyio
import anyio.lowlevel

from skill_agent._errors import (
    ParameterError,
    ParameterTypeError,
    PreconditionError,
    RunStateError,
    SkillFailure,
    leaves,
)
from skill_agent._skill import Skill
from skill_agent.conditions._effects import effects
from skill_agent.conditions._eval import evaluate, evaluate_all
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
from skill_agent.runtime._run_wm import RunWm
from skill_agent.runtime._simulated import SimulatedOutcomes
from wm_store import WmClient
from wm_store.protocol import Change, Element, Op, Value

__all__ = ["ChildRunner", "Run", "RunContext", "RunEnv"]

T = TypeVar("T")
_log = logging.getLogger(__name__)

ChildRunner = Callable[["Run", str, Mapping[str, Value]], Awaitable[RunResult]]
"""``(parent, skill, params) -> result``: runs a sub-run inside the parent's task."""

_FINAL: dict[ResultReason, RunState] = {"ok": "succeeded", "preempted": "preempted"}
_PREEMPTING: frozenset[ResultReason] = frozenset({"preempted", "timeout", "hold_violated", "error"})


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


class RunContext:
    """The :class:`~skill_agent.SkillContext` of one run."""

    def __init__(self, run: Run) -> None:
        self._run = run
        self.run_id = run.run_id
        self.agent = run.env.agent
        self.description = run.description
        self.params: Mapping[str, Value] = run.params
        self.simulated = run.simulated
        self.log = logging.getLogger(f"skill_agent.skills.{run.description.name}")
        self._wm = RunWm(run.env.wm, run.wrote)

    @property
    def wm(self) -> RunWm:
        """The agent's world-model client as this run's view: reads as the client, every
        committed write also recorded in the event log (:class:`~skill_agent.runtime.RunWm`)."""
        return self._wm

    def element(self, param: str) -> Element:
        """The element bound to ``param``; raises ParameterError if it is no element id."""
        value = self.params.get(param)
        if not isinstance(value, str):
            raise ParameterError(f"parameter {param!r} of {self.description.name} is no element")
        return self.wm.get_element(value)

    def device(self, param: str, kind: type[T]) -> T:
        """The driver bound to hardware parameter ``param``. Raises RunStateError when
        simulated, ParameterError / ParameterTypeError when there is no such driver."""
        if self.simulated:
            raise RunStateError(f"run {self.run_id} is simulated: no hardware for {param!r}")
        spec = next((p for p in self.description.parameters if p.name == param), None)
        if spec is None or spec.kind != "hardware":
            raise ParameterError(
                f"{param!r} is not a hardware parameter of {self.description.name}"
            )
        device_id = self.params.get(param)
        driver = self._run.env.devices.get(device_id) if isinstance(device_id, str) else None
        if driver is None:
            raise ParameterError(f"agent {self.agent} has no driver for device {device_id!r}")
        if not isinstance(driver, kind):
            raise ParameterTypeError(
                f"device {device_id} is a {type(driver).__name__}, not a {kind.__name__}"
            )
        return driver

    async def progress(self, message: str, *, fraction: float = -1.0, step: str = "") -> None:
        """Publish a progress event (also a cancellation point)."""
        await anyio.lowlevel.checkpoint()
        self._run.progress(message, fraction=fraction, step=step)

    async def checkpoint(self) -> None:
        """Hold while this run (or a parent) is paused; a cancellation point otherwise."""
        await self._run.checkpoint()

    async def run_child(self, skill: str, params: Mapping[str, Value]) -> RunResult:
        """Run ``skill`` as a sub-run (composite skills); returns its result. Raises the
        start refusals (UnknownSkillError, ParameterError, ResourceBusyError)."""
        if self._run.env.run_child is None:
            raise RunStateError(f"agent {self.agent} cannot run sub-skills")
        return await self._run.env.run_child(self._run, skill, params)

    async def transact(self, ops: Sequence[Op]) -> int:
        """Commit ``ops`` in one world-model transaction (recorded in the event log, as every
        write through :attr:`wm`); returns its revision."""
        return await self._run.commit(list(ops))


class Run:
    """Drives one run. Create, then ``await drive()`` in a task (see the module docstring)."""

    def __init__(
        self,
        env: RunEnv,
        *,
        run_id: str,
        skill: Skill,
        description: SkillDescription,
        params: Mapping[str, Value],
        resources: Sequence[str] = (),
        timeout: float | None = None,
        outcomes: SimulatedOutcomes | None = None,
        parent: Run | None = None,
        acquire: Callable[[], Awaitable[None]] | None = None,
    ) -> None:
        self.env, self.run_id, self.skill, self.description = env, run_id, skill, description
        self.params = dict(params)
        self.resources = list(resources)
        self.timeout = timeout if timeout is not None else description.timeout
        self.outcomes, self.parent, self._acquire = outcomes, parent, acquire
        self.simulated = outcomes is not None
        self.started_at = time.time()
        self.context = RunContext(self)
        self._state: RunState = "pending"
        self._step = ""
        self._seq = 0
        self._scope = anyio.CancelScope()
        self._stop: tuple[ResultReason, str] | None = None
        self._resumed: anyio.Event | None = None
        self._touched = False  # a skill method was entered: on_preempt is due after a cut
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
        """Cancel the run (it ends at the skill's next await); idempotent, never blocks."""
        if self.result is None:
            self._stop = self._stop or (reason, message)
            self._scope.cancel()

    def abandon(self, message: str) -> None:
        """End a run whose task is gone without driving it (result ``preempted``)."""
        if self.result is None:
            self._finish("preempted", message)

    def pause(self) -> None:
        """Hold at the next checkpoint. Raises RunStateError if ended or already paused."""
        if self.result is not None or self._resumed is not None:
            raise RunStateError(f"run {self.run_id} is {self.state}; it cannot be paused")
        self._resumed = anyio.Event()
        self._emit_progress("paused", "paused; holds at its next checkpoint")

    def resume(self) -> None:
        """Release a paused run. Raises RunStateError if it is not paused."""
        if self.result is not None or self._resumed is None:
            raise RunStateError(f"run {self.run_id} is {self.state}, not paused")
        resumed, self._resumed = self._resumed, None
        resumed.set()
        self._emit_progress(self._state, "resumed")

    async def checkpoint(self) -> None:
        await anyio.lowlevel.checkpoint()
        run: Run | None = self
        while run is not None:
            if run._resumed is not None:
                await run._resumed.wait()
                run = self  # re-check the whole chain after waking
            else:
                run = run.parent

    def progress(self, message: str, *, fraction: float = -1.0, step: str = "") -> None:
        self._emit_progress(self.state, message, fraction=fraction, step=step or self._step)

    # ------------------------------------------------------------------ driving

    async def drive(self) -> RunResult:
        """Run the lifecycle; returns the result. Raises nothing but the cancellation of an
        enclosing scope (the agent shutting down), re-raised after ``on_preempt`` and the
        result."""
        self._step = "start"
        devices = ", ".join(self.resources) or "none"
        queued = self._acquire is not None
        self._emit_progress("pending", f"{'queued for' if queued else 'holds'} devices: {devices}")
        try:
            reason, message = await self._guarded()
        except anyio.get_cancelled_exc_class():
            with anyio.CancelScope(shield=True):
                self._finish("preempted", "the agent stopped" + await self._preempt())
            raise
        if reason in _PREEMPTING:
            message += await self._preempt()
        return self._finish(reason, message)

    async def _guarded(self) -> tuple[ResultReason, str]:
        outcome: tuple[ResultReason, str] = ("error", "the run ended without an outcome")
        try:
            with self._scope:
                if self._acquire is not None:
                    await self._acquire()
                    self._emit_progress("pending", "devices acquired")
                if self.timeout is not None:
                    self._scope.deadline = anyio.current_time() + self.timeout
                outcome = await self._lifecycle()
        except Exception as exc:
            outcome = self._failure(exc)
        if self._stop is not None and outcome[0] != "ok":
            return self._stop
        timed_out = outcome[0] != "ok" and anyio.current_time() >= self._scope.deadline
        if self._scope.cancelled_caught or timed_out:
            return "timeout", f"timed out after {self.timeout} s in {self._step or 'pending'}"
        return outcome

    def _failure(self, exc: Exception) -> tuple[ResultReason, str]:
        found = leaves(exc)
        if all(isinstance(e, SkillFailure) for e in found):
            return "execution", "; ".join(str(e) for e in found)
        _log.error("run %s: unexpected error in %s", self.run_id, self._step, exc_info=exc)
        return "error", f"{self._step or 'start'}: " + "; ".join(
            f"{type(e).__name__}: {e}" for e in found
        )

    async def _lifecycle(self) -> tuple[ResultReason, str]:
        desc, env, ctx = self.description, self.env, self.context
        composite = bool(getattr(self.skill, "runs_children", False))
        real = not self.simulated
        if real:
            await self._sense("pre_sense", self.skill.pre_sense)
        await self._enter("checking_pre", "pre_conditions")
        verdict = evaluate_all(desc.pre, env.wm, self.params, registry=env.registry)
        if not verdict.ok:
            if not self._accepted.is_set():
                self.refusal = PreconditionError(
                    f"{desc.name}: pre-condition false: {verdict.reason}"
                )
            return "precondition", verdict.reason
        await self._enter("executing", "execute")
        self._accepted.set()
        with self._hold_watch():
            if real or composite:
                self._touched = True
                await self.skill.execute(ctx)
            else:
                assert self.outcomes is not None
                failure = await self.outcomes.play(desc, type(self.skill))
                if failure is not None:
                    return "execution", failure
        if real:
            await self._sense("post_sense", self.skill.post_sense)
        await self._enter("checking_post", "post_conditions")
        ops, failed = self._predicted_effects(strict=real)
        if failed is not None:
            return "postcondition", failed
        if ops:
            await self._enter("committing", "commit", f"{len(ops)} effect(s)")
            with anyio.CancelScope(shield=True):
                self._effects_revision = await self.commit(ops)
        return "ok", "simulated success" if self.simulated and not composite else "done"

    async def commit(self, ops: list[Op]) -> int:
        """Commit ``ops`` through the run's world-model view (recorded); the revision."""
        return (await self.context.wm.transact(ops)).revision

    def wrote(self, ops: list[Op], revision: int) -> None:
        """Record a transaction this run committed (called by its :class:`RunWm`), tagged
        with the step it was in (``execute``, ``commit``, ``preempt``, ...)."""
        if self.env.on_write is not None:
            entry = WmWriteEntry(
                agent=self.env.agent,
                run_id=self.run_id,
                revision=revision,
                ops=ops,
                step=self._step,
            )
            self.env.on_write(entry)

    async def _sense(self, step: str, method: Callable[[RunContext], Awaitable[None]]) -> None:
        state: RunState = "pre_sense" if step == "pre_sense" else "post_sense"
        fresh = self._fresh_data()
        if fresh is not None:
            self._trusted.append(step)
            await self._enter(state, step, f"skipped: world model fresh ({fresh})")
            return
        await self._enter(state, step)
        self._touched = True
        await method(self.context)

    def _fresh_data(self) -> str | None:
        """Why sensing may be skipped, or None."""
        max_age, senses = self.description.sensing_max_age, type(self.skill).senses
        if max_age is None or not senses:
            return None
        now, ages = time.time(), []
        for param in senses:
            value = self.params.get(param)
            element = self.env.wm.find_element(value) if isinstance(value, str) else None
            if element is None or now - element.updated_at > max_age:
                return None
            ages.append(f"{element.id} {now - element.updated_at:.2f} s old")
        return ", ".join(ages) + f" <= {max_age} s"

    def _predicted_effects(self, *, strict: bool) -> tuple[list[Op], str | None]:
        """The ops making the post-conditions true, or why one is false and cannot be made
        true (a checked-only condition; ignored when not ``strict``)."""
        view, registry, post = self.env.wm, self.env.registry, self.description.post
        for cond in post:
            verdict = evaluate(cond, view, self.params, registry=registry)
            if strict and not verdict.ok and not effects([cond], view, self.params):
                return [], verdict.reason
        return effects(post, view, self.params), None

    @contextmanager
    def _hold_watch(self) -> Iterator[None]:
        if not self.description.hold:
            yield
            return

        def check(_change: Change | None = None) -> None:
            try:
                verdict = evaluate_all(
                    self.description.hold, self.env.wm, self.params, registry=self.env.registry
                )
            except Exception as exc:
                self.stop("error", f"hold-condition check failed: {type(exc).__name__}: {exc}")
                return
            if not verdict.ok:
                self.stop("hold_violated", verdict.reason)

        unsubscribe = self.env.wm.on_change(check)
        try:
            check()
            yield
        finally:
            unsubscribe()

    async def _enter(self, state: RunState, step: str, message: str = "") -> None:
        await self.checkpoint()
        self._state, self._step = state, step
        self._emit_progress(state, message)

    async def _preempt(self) -> str:
        """Call on_preempt shielded with the time limit; returns a note for the message."""
        if not self._touched or (self.simulated and not getattr(self.skill, "runs_children", 0)):
            return ""
        limit = self.env.preempt_timeout
        with anyio.CancelScope(shield=True):
            self._step = "preempt"  # the step on_preempt's world-model writes are recorded in
            self._emit_progress(self.state, "bringing the hardware to a safe state")
            with anyio.move_on_after(limit) as scope:
                try:
                    await self.skill.on_preempt(self.context)
                except Exception as exc:
                    _log.error("run %s: on_preempt failed", self.run_id, exc_info=exc)
                    return f"; on_preempt failed: {type(exc).__name__}: {exc}"
        return f"; on_preempt did not finish within {limit} s" if scope.cancelled_caught else ""

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
