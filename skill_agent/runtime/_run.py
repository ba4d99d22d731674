"""One run of a skill: :class:`Run` drives the lifecycle (its state, commands and events are
:class:`~skill_agent.runtime._control.RunControl`'s; :class:`RunContext` is what the skill
sees).

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
  :meth:`RunContext.checkpoint`, as the standard skills do before each motion), and the agent
  pauses the run's pausable devices (:class:`~skill_agent.runtime._device_hold.DeviceHold`):
  a motion under way comes to rest on its path and goes on at the resume. The deadline stops
  while paused (the time left counts again from the resume). A run stopped while paused
  resumes its devices first: the motion cut by the stop has halted (``MotionStoppedError``),
  the others are free for ``on_preempt``.
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

import anyio

from skill_agent._errors import PreconditionError, SkillFailure, leaves
from skill_agent._skill import Skill
from skill_agent.conditions._effects import effects
from skill_agent.conditions._eval import evaluate, evaluate_all
from skill_agent.protocol._log import WmWriteEntry
from skill_agent.protocol._runs import ResultReason, RunResult, RunState
from skill_agent.protocol._skills import SkillDescription
from skill_agent.runtime._context import RunContext
from skill_agent.runtime._control import RunControl, RunEnv
from skill_agent.runtime._simulated import SimulatedOutcomes
from wm_store import display_name
from wm_store.protocol import Change, Op, Value

__all__ = ["Run"]

_log = logging.getLogger(__name__)

_PREEMPTING: frozenset[ResultReason] = frozenset({"preempted", "timeout", "hold_violated", "error"})


class Run(RunControl):
    """Drives one run. Create, then ``await drive()`` in a task (see the module docstring)."""

    parent: Run | None

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
        super().__init__(
            env,
            run_id=run_id,
            description=description,
            params=params,
            resources=resources,
            parent=parent,
        )
        self.skill = skill
        self.timeout = timeout if timeout is not None else description.timeout
        self.outcomes, self._acquire = outcomes, acquire
        self.acquired = acquire is None
        """The run holds its devices (a queued run: once its turn came)."""
        self.simulated = outcomes is not None
        self.context = RunContext(self)
        self._touched = False  # a skill method was entered: on_preempt is due after a cut

    async def drive(self) -> RunResult:
        """Run the lifecycle; returns the result. Raises nothing but the cancellation of an
        enclosing scope (the agent shutting down), re-raised after ``on_preempt`` and the
        result."""
        self._step = "start"
        wm = self.env.wm
        devices = ", ".join(display_name(wm.find_element(d), d) for d in self.resources) or "none"
        queued = self._acquire is not None
        self._emit_progress("pending", f"{'queued for' if queued else 'holds'} devices: {devices}")
        try:
            reason, message = await self._guarded()
        except anyio.get_cancelled_exc_class():
            with anyio.CancelScope(shield=True):
                await self.devices.resume()
                self._finish("preempted", "the agent stopped" + await self._preempt())
            raise
        await self.devices.resume()  # a run stopped while paused frees its devices first
        if reason in _PREEMPTING:
            message += await self._preempt()
        return self._finish(reason, message)

    async def _guarded(self) -> tuple[ResultReason, str]:
        outcome: tuple[ResultReason, str] = ("error", "the run ended without an outcome")
        try:
            with self._scope:
                if self._acquire is not None:
                    await self._acquire()
                    self.acquired = True
                    self._emit_progress("pending", "devices acquired")
                if self.timeout is not None:
                    self.set_deadline(self.timeout)
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
