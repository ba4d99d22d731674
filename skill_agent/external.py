"""Foreign code as a skill: :class:`ExternalServiceSkill` drives an external service that speaks a
tiny goal / feedback / cancel protocol over Zenoh (the role actionlib played for SkiROS).

Key space, under ``skimesh/<mesh>/services/<service>`` (``<service>`` is one or more name
segments, e.g. ``partner/door``)::

    <service>/goal              queryable   Goal        -> GoalAccepted | GoalRejected
    <service>/cancel            queryable   CancelGoal  -> CancelAck
    <service>/feedback/<goal>   publication Feedback ... then exactly one Outcome (last)
    <service>/alive             liveliness token of the service (optional)

Message flow of one run (``<goal>`` is the run id)::

    adapter: subscribe feedback/<goal>, watch alive      (before the goal is sent: nothing missed)
    adapter -> goal:   Goal{goal_id, skill, params}      <- GoalAccepted  (or GoalRejected: fails)
    service -> feedback/<goal>: Feedback{message, fraction} ...  -> run progress events
    service -> feedback/<goal>: Outcome{success, message}        -> run succeeds / fails
    stop:    adapter -> cancel: CancelGoal{goal_id}      <- CancelAck{known}   (in on_preempt)

Payloads are MessagePack (msgspec) with the tag field ``msg`` and ``schema_version``, so any
language with MessagePack and Zenoh can be a service. If the service's ``alive`` token was seen
and disappears, the run fails at once; otherwise the run's own ``timeout`` bounds the wait.

A service skill is an ordinary :class:`~skill_agent.Skill` subclass (set
:attr:`~ExternalServiceSkill.service` and ``description``) or comes from an agent config's
``[[services]]`` table (:func:`external_skill`). The agent gives it its mesh session
(the skill registry passes ``mesh=`` to skill classes whose ``__init__`` accepts it).
"""

from __future__ import annotations

import logging
from dataclasses import dataclass
from typing import Any, ClassVar, TypeAlias

import anyio
import msgspec
from msgspec import Struct

from meshlink import Liveness, Mesh, MeshlinkError, RemoteError, Sample, Subscription, check_name
from skill_agent._errors import SkillFailure
from skill_agent._skill import Skill, SkillContext
from skill_agent.protocol._skills import SkillDescription
from wm_store.protocol import Value

__all__ = [
    "SCHEMA_VERSION",
    "CancelAck",
    "CancelGoal",
    "ExternalServiceSkill",
    "Feedback",
    "Goal",
    "GoalAccepted",
    "GoalRejected",
    "Outcome",
    "ServiceEvent",
    "ServiceKeys",
    "ServiceReply",
    "ServiceRequest",
    "decode_service_event",
    "decode_service_reply",
    "decode_service_request",
    "encode",
    "external_skill",
]

_log = logging.getLogger(__name__)
SCHEMA_VERSION = 1


class Goal(Struct, tag=True, tag_field="msg", frozen=True, kw_only=True):
    goal_id: str
    skill: str = ""
    params: dict[str, Value] = {}
    schema_version: int = SCHEMA_VERSION


class CancelGoal(Struct, tag=True, tag_field="msg", frozen=True, kw_only=True):
    goal_id: str
    schema_version: int = SCHEMA_VERSION


class GoalAccepted(Struct, tag=True, tag_field="msg", frozen=True, kw_only=True):
    goal_id: str
    schema_version: int = SCHEMA_VERSION


class GoalRejected(Struct, tag=True, tag_field="msg", frozen=True, kw_only=True):
    goal_id: str
    reason: str = ""
    schema_version: int = SCHEMA_VERSION


class CancelAck(Struct, tag=True, tag_field="msg", frozen=True, kw_only=True):
    goal_id: str
    known: bool = True
    """False if the service had no such goal running (already finished, or never accepted)."""
    schema_version: int = SCHEMA_VERSION


class Feedback(Struct, tag=True, tag_field="msg", frozen=True, kw_only=True):
    goal_id: str
    message: str = ""
    fraction: float = -1.0
    schema_version: int = SCHEMA_VERSION


class Outcome(Struct, tag=True, tag_field="msg", frozen=True, kw_only=True):
    goal_id: str
    success: bool
    message: str = ""
    schema_version: int = SCHEMA_VERSION


ServiceRequest: TypeAlias = Goal | CancelGoal
ServiceReply: TypeAlias = GoalAccepted | GoalRejected | CancelAck
ServiceEvent: TypeAlias = Feedback | Outcome

_encoder = msgspec.msgpack.Encoder()
_requests = msgspec.msgpack.Decoder(ServiceRequest)
_replies = msgspec.msgpack.Decoder(ServiceReply)
_events = msgspec.msgpack.Decoder(ServiceEvent)


def encode(message: Any) -> bytes:
    return _encoder.encode(message)


def decode_service_request(data: bytes) -> ServiceRequest:
    return _requests.decode(data)  # type: ignore[no-any-return]  # union decoder is untyped


def decode_service_reply(data: bytes) -> ServiceReply:
    return _replies.decode(data)  # type: ignore[no-any-return]  # union decoder is untyped


def decode_service_event(data: bytes) -> ServiceEvent:
    return _events.decode(data)  # type: ignore[no-any-return]  # union decoder is untyped


@dataclass(frozen=True, slots=True)
class ServiceKeys:
    """Key expressions of one service (``prefix`` is ``mesh.keys.prefix``)."""

    prefix: str
    service: str

    def __post_init__(self) -> None:
        for segment in self.service.split("/"):
            check_name(segment, "service name segment")

    @property
    def base(self) -> str:
        return f"{self.prefix}/services/{self.service}"

    def goal(self) -> str:
        return f"{self.base}/goal"

    def cancel(self) -> str:
        return f"{self.base}/cancel"

    def feedback(self, goal_id: str) -> str:
        return f"{self.base}/feedback/{check_name(goal_id, 'goal id')}"

    def alive(self) -> str:
        return f"{self.base}/alive"


class ExternalServiceSkill(Skill):
    """A skill whose ``execute`` sends a goal to an external service and follows it.

    Subclasses set ``description`` and :attr:`service`; override :meth:`goal_params` to send
    something other than the run's parameters."""

    service: ClassVar[str] = ""
    goal_timeout: ClassVar[float] = 5.0
    """Seconds to wait for the service to accept or reject a goal."""
    cancel_timeout: ClassVar[float] = 2.0

    def __init__(self, *, mesh: Mesh | None = None) -> None:
        self.mesh = mesh

    def goal_params(self, ctx: SkillContext) -> dict[str, Value]:
        return dict(ctx.params)

    def _keys(self) -> tuple[Mesh, ServiceKeys]:
        if self.mesh is None:
            raise SkillFailure(
                f"skill {self.description.name!r} drives the service {self.service!r} and needs "
                "a mesh session: run it in an agent connected to Zenoh"
            )
        return self.mesh, ServiceKeys(self.mesh.keys.prefix, self.service)

    async def execute(self, ctx: SkillContext) -> None:
        mesh, keys = self._keys()
        goal = Goal(goal_id=ctx.run_id, skill=self.description.name, params=self.goal_params(ctx))
        async with (
            mesh.subscribe(keys.feedback(goal.goal_id)) as events,
            mesh.watch_liveliness(keys.alive()) as presence,
        ):
            reply = await self._ask(mesh, keys.goal(), goal)
            if isinstance(reply, GoalRejected):
                raise SkillFailure(f"service {self.service!r} rejected the goal: {reply.reason}")
            if not isinstance(reply, GoalAccepted):
                raise SkillFailure(f"service {self.service!r} answered {type(reply).__name__}")
            outcome = await self._follow(ctx, events, presence)
        if not outcome.success:
            raise SkillFailure(f"service {self.service!r} failed: {outcome.message}")

    async def _ask(self, mesh: Mesh, key: str, request: ServiceRequest) -> ServiceReply:
        try:
            data = await mesh.request(key, encode(request), timeout=self.goal_timeout)
            return decode_service_reply(data)
        except RemoteError as e:
            raise SkillFailure(f"service {self.service!r} refused: {e}") from None
        except (MeshlinkError, msgspec.MsgspecError) as e:
            raise SkillFailure(f"service {self.service!r} unreachable: {e}") from None

    async def _follow(
        self, ctx: SkillContext, events: Subscription[Sample], presence: Subscription[Liveness]
    ) -> Outcome:
        outcome: Outcome | None = None
        lost = False

        async def watch_presence() -> None:
            nonlocal lost
            seen = False
            async for change in presence:
                seen = seen or change.alive
                if seen and not change.alive:
                    lost = True
                    tg.cancel_scope.cancel()
                    return

        async with anyio.create_task_group() as tg:
            tg.start_soon(watch_presence)
            async for sample in events:
                try:
                    event = decode_service_event(sample.payload)
                except msgspec.MsgspecError as e:
                    _log.warning("undecodable event from service %s: %s", self.service, e)
                    continue
                if isinstance(event, Outcome):
                    outcome = event
                    break
                await ctx.progress(event.message, fraction=event.fraction, step="service")
                await ctx.checkpoint()
            tg.cancel_scope.cancel()
        if outcome is None:
            why = "its liveliness token disappeared" if lost else "its feedback stream ended"
            raise SkillFailure(f"service {self.service!r} lost: {why}")
        return outcome

    async def on_preempt(self, ctx: SkillContext) -> None:
        """Cancel the goal (best effort, bounded by ``cancel_timeout``)."""
        if self.mesh is None:
            return
        mesh, keys = self._keys()
        with anyio.move_on_after(self.cancel_timeout):
            try:
                await mesh.request(
                    keys.cancel(),
                    encode(CancelGoal(goal_id=ctx.run_id)),
                    timeout=self.cancel_timeout,
                )
            except MeshlinkError as e:
                _log.warning("could not cancel goal %s on %s: %s", ctx.run_id, self.service, e)


def external_skill(
    description: SkillDescription, service: str, *, goal_timeout: float = 5.0
) -> type[ExternalServiceSkill]:
    """A :class:`ExternalServiceSkill` subclass for ``description`` served by ``service``."""
    ServiceKeys("x", service)  # checks the service name now, not at the first run
    name = "".join(part.capitalize() for part in description.name.replace("-", "_").split("_"))
    attrs = {
        "description": description,
        "service": service,
        "goal_timeout": goal_timeout,
        "__module__": __name__,
        "__doc__": description.doc or f"Skill {description.name!r} served by {service!r}.",
    }
    return type(f"{name}Service", (ExternalServiceSkill,), attrs)
