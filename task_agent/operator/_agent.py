"""The operator agent's parts: :class:`OperatorDesk` (pending requests), :class:`OperatorSkill`,
:class:`SkillMirror`, :class:`OperatorService` and :func:`serve_operator` (what they do is in
:mod:`task_agent.operator`)."""

from __future__ import annotations

import functools
import logging
import time
from collections.abc import Sequence
from typing import cast

import anyio
import msgspec
from anyio.abc import TaskStatus

from meshlink import Mesh
from meshlink.rpc import DEFAULT_MAX_REQUEST_BYTES, RequestHandler, coded_errors
from skill_agent import Skill, SkillContext, SkillFailure
from skill_agent.protocol import ParamSpec, SkillDescription
from skill_agent.runtime import AgentCore, SkillEntry
from skill_agent.server import AgentService, RunEventPublisher
from wm_store import WmClient, WmError
from wm_store.protocol import AddElement, Op, UpdateElement, Value

from .._client import operator_rpc_key
from .._errors import RequestError, TaskError
from ..discovery import OPERATOR_CLASS, Discovery
from ..execution import OPERATOR_NOTE
from ..protocol import (
    AnswerPending,
    ListPending,
    OkReply,
    OperatorReply,
    OperatorRequest,
    PendingReply,
    PendingStep,
    SeenAt,
)
from ._sightings import seen_text, sighting_ops

__all__ = [
    "OperatorDesk",
    "OperatorService",
    "OperatorSkill",
    "SkillMirror",
    "serve_operator",
]

_log = logging.getLogger(__name__)
UNKNOWN_REQUEST = "unknown_request"


class _Pending:
    def __init__(self, step: PendingStep) -> None:
        self.step = step
        self.answered = anyio.Event()
        self.answer = Answered(False)


class Answered(msgspec.Struct, frozen=True):
    """A person's answer to one request: done or not, what they said, what they saw."""

    success: bool
    message: str = ""
    seen: tuple[SeenAt, ...] = ()


class OperatorDesk:
    """The requests waiting for a person. Requests get short ids ``1``, ``2``, ... ."""

    def __init__(self) -> None:
        self._pending: dict[str, _Pending] = {}
        self._count = 0
        self._changed = anyio.Event()

    def pending(self) -> list[PendingStep]:
        return [p.step for p in self._pending.values()]

    async def ask(self, ctx: SkillContext) -> Answered:
        """Open a request for ``ctx``'s run and wait for the answer. Cancelling (the run
        stopped) withdraws it."""
        self._count += 1
        params = dict(ctx.params)
        note = params.pop(OPERATOR_NOTE, "")
        step = PendingStep(
            id=str(self._count),
            run_id=ctx.run_id,
            skill=ctx.description.name,
            params=params,
            note=note if isinstance(note, str) else str(note),
            asked_at=time.time(),
        )
        pending = self._pending[step.id] = _Pending(step)
        self._wake()
        try:
            await ctx.progress(f"waiting for the operator: request {step.id}", step="operator")
            await pending.answered.wait()
            return pending.answer
        finally:
            del self._pending[step.id]
            self._wake()

    def answer(
        self,
        request_id: str,
        success: bool,
        message: str = "",
        seen: Sequence[SeenAt] = (),
    ) -> PendingStep:
        """Answer a pending request. Raises KeyError (with the pending ids) if there is none."""
        pending = self._pending.get(request_id)
        if pending is None or pending.answered.is_set():
            have = ", ".join(self._pending) or "none"
            raise KeyError(f"no pending operator request {request_id!r} (pending: {have})")
        pending.answer = Answered(success, message, tuple(seen))
        pending.answered.set()
        return pending.step

    async def wait_changed(self) -> None:
        await self._changed.wait()

    def _wake(self) -> None:
        changed, self._changed = self._changed, anyio.Event()
        changed.set()


class OperatorSkill(Skill):
    """Every skill of the operator agent: a person does the work (see the module doc)."""

    def __init__(self, desk: OperatorDesk) -> None:
        self.desk = desk

    async def execute(self, ctx: SkillContext) -> None:
        answer = await self.desk.ask(ctx)
        message = answer.message
        if not answer.success:
            raise SkillFailure(f"the operator could not do it: {message or 'no reason given'}")
        if answer.seen:
            wm = cast(WmClient, ctx.wm)
            await ctx.transact(sighting_ops(wm, ctx.agent, answer.seen))
            where = ", ".join(seen_text(s) for s in answer.seen)
            message = f"{message}; seen: {where}" if message else f"seen: {where}"
        await ctx.progress(f"done by the operator: {message or 'ok'}", step="operator")


def operator_description(desc: SkillDescription) -> SkillDescription:
    """``desc`` as the operator offers it: plus the ``operator_note`` text, no time limit."""
    note = ParamSpec(
        name=OPERATOR_NOTE, type="str", kind="offline", default="", doc="what to do and why"
    )
    params = [p for p in desc.parameters if p.name != OPERATOR_NOTE]
    return msgspec.structs.replace(desc, parameters=[*params, note], timeout=None)


class SkillMirror:
    """The skills of the robot agents registered in the world model, as operator skills (the
    first agent by name wins when two describe a skill differently)."""

    def __init__(self, discovery: Discovery, desk: OperatorDesk) -> None:
        self.discovery = discovery
        self.desk = desk
        self.descriptions: dict[str, SkillDescription] = {}

    def refresh(self) -> bool:
        """Read the registrations again; True if the skills changed."""
        found: dict[str, SkillDescription] = {}
        for agent in self.discovery.agents(include_unavailable=True):
            for desc in agent.skills:
                found.setdefault(desc.name, operator_description(desc))
        changed, self.descriptions = found != self.descriptions, found
        return changed

    def entries(self) -> dict[str, SkillEntry]:
        factory = functools.partial(OperatorSkill, self.desk)
        return {
            name: SkillEntry(description=d, factory=factory, source="task_agent.operator")
            for name, d in sorted(self.descriptions.items())
        }

    async def follow(self, wm: WmClient, core: AgentCore) -> None:
        """Keep ``core``'s skills equal to the mirror until cancelled (one refresh per burst
        of world-model changes)."""
        changed = anyio.Event()

        def mark(_change: object) -> None:
            changed.set()

        unsubscribe = wm.on_change(mark)
        try:
            while True:
                if self.refresh():
                    core.replace_skills(self.entries())
                    _log.info("operator skills: %s", ", ".join(self.descriptions) or "none")
                await changed.wait()
                changed = anyio.Event()
        finally:
            unsubscribe()


class OperatorService:
    """``operator/rpc`` requests -> replies (transport-free). Errors: an id that is not pending
    answers ``unknown_request``; malformed bytes ``bad_request``, a request over
    ``max_request_bytes`` ``too_large`` (:mod:`meshlink.rpc`)."""

    def __init__(
        self, name: str, desk: OperatorDesk, *, max_request_bytes: int = DEFAULT_MAX_REQUEST_BYTES
    ) -> None:
        self.name = name
        self.desk = desk
        self.rpc: RequestHandler[OperatorRequest, OperatorReply] = RequestHandler(
            OperatorRequest,
            self.handle,
            errors=coded_errors(TaskError),
            max_request_bytes=max_request_bytes,
            name="operator/rpc",
        )

    async def handle_bytes(self, data: bytes) -> tuple[bytes, bool]:
        """Decode, answer, encode (:attr:`rpc`); never raises. Returns ``(payload, ok)``."""
        return await self.rpc.handle_bytes(data)

    async def handle(self, request: OperatorRequest) -> OperatorReply:
        """Answer one request; refusals raise :class:`~task_agent.RequestError`."""
        match request:
            case ListPending():
                return PendingReply(agent=self.name, pending=self.desk.pending())
            case AnswerPending(id=request_id, success=success, message=message, seen=seen):
                try:
                    step = self.desk.answer(request_id, success, message, seen)
                except KeyError as e:
                    raise RequestError(UNKNOWN_REQUEST, e.args[0]) from None
                verdict = "done" if success else "failed"
                who = f" by {request.author}" if request.author else ""
                _log.warning(
                    "operator request %s (%s) answered %s%s", step.id, step.skill, verdict, who
                )
                return OkReply(message=f"request {step.id} ({step.skill}) answered: {verdict}")


async def _register(wm: WmClient, name: str, address: str) -> None:
    """An ``Operator`` element labelled ``name`` (reused if there is one)."""
    props: dict[str, Value] = {"available": True, "address": address}
    found = wm.resolve_element(type=OPERATOR_CLASS, label=name)
    ops: list[Op] = (
        [UpdateElement(id=found[0].id, properties=props)]
        if found
        else [AddElement(type=OPERATOR_CLASS, label=name, properties=props)]
    )
    await wm.transact(ops)


async def serve_operator(
    mesh: Mesh,
    wm: WmClient,
    *,
    name: str = "operator",
    discovery: Discovery | None = None,
    task_status: TaskStatus[None] = anyio.TASK_STATUS_IGNORED,
) -> None:
    """Serve the operator agent ``name`` until cancelled (see the module doc); ``started``
    once it is reachable and registered."""
    keys, desk = mesh.keys, OperatorDesk()
    mirror = SkillMirror(discovery or Discovery(wm), desk)
    mirror.refresh()
    core = AgentCore(name=name, wm=wm, skills=mirror.entries())
    agent_service, operator = AgentService(core), OperatorService(name, desk)

    publisher = RunEventPublisher(mesh, name)
    unsubscribe = publisher.attach(core)  # run progress and the event log
    token = None
    try:
        async with anyio.create_task_group() as tg:
            tg.start_soon(publisher.run)
            await tg.start(core.run)
            skills_key, rpc_key = keys.agent_skills(name), keys.agent_rpc(name)
            await tg.start(mesh.serve, skills_key, agent_service.skills.serve_on(skills_key))
            await tg.start(mesh.serve, rpc_key, agent_service.rpc.serve_on(rpc_key))
            answers = operator_rpc_key(keys)
            await tg.start(mesh.serve, answers, operator.rpc.serve_on(answers))
            token = mesh.declare_token(keys.agent(name))
            await _register(wm, name, keys.agent(name))
            tg.start_soon(mirror.follow, wm, core)
            _log.info("operator agent %s ready on mesh %r", name, keys.mesh)
            task_status.started()
    finally:
        unsubscribe()
        publisher.flush()
        with anyio.CancelScope(shield=True):
            if token is not None:
                with anyio.move_on_after(5.0):
                    try:
                        await wm.unregister_robot(name)
                    except WmError as e:
                        _log.info(  # not a fault: the store follows the token (presence)
                            "operator %s not unregistered (%s); the store marks it unavailable "
                            "when its liveliness token goes",
                            name,
                            e,
                        )
                token.undeclare()
