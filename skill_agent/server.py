"""``skimesh agent``: a skill agent served over Zenoh.

This module is the skill layer's Zenoh adapter (the runtime itself, :class:`AgentCore`, knows
no network). For an agent ``<a>`` (keys under ``skimesh/<mesh>``):

- ``agents/<a>/skills``  queryable: :class:`~skill_agent.protocol.SkillsReply` to an empty
  payload or an encoded :class:`~skill_agent.protocol.ListSkills`; any other payload (bytes
  that are no request, another request) gets an error reply ``bad_request``
  (:meth:`AgentService.skills_bytes`);
- ``agents/<a>/rpc``     queryable: one :data:`AgentRequest` -> one :data:`AgentReply`; every
  refusal is a Zenoh *error reply* carrying an :class:`ErrorReply` (``code`` = the error class's
  code, so the client re-raises the same class). Undecodable bytes, unknown tags and wrong
  field types answer ``bad_request``; an unexpected exception answers ``internal``: no request
  crashes the agent or changes state;
- ``agents/<a>/runs/<run>/progress``  publication (BLOCK): every :data:`RunEvent` of the run,
  in order, ending with its :class:`RunResult`; progress events may wait up to 2 ms to go out
  in a burst, a result goes at once (:class:`RunEventPublisher`);
- ``agents/<a>/events``  publication (BLOCK): every :data:`~skill_agent.protocol.LogEntry` of
  the agent's event log (runs started, progress, results, refused starts, world-model writes),
  in order, through the same publisher (queued on the loop, sent in the same bursts; a run's
  entries go out before its result on the progress key);
- ``agents/<a>``  liveliness token, declared once the queryables are up, so whoever sees the
  agent alive can call it.

Start-up order: core running -> queryables -> token -> registration in the world model (agent,
robot, devices, skills: :meth:`WmClient.register_robot`; the presence monitor of the store then
keeps ``available`` equal to the token) -> wiring: the drivers given (by label: in-process
drivers of a simulated world, or Zenoh proxies from
:func:`~device_drivers.remote.connect_devices`) are bound to the elements of the
registered robot and devices, and the configuration's ``[hardware]`` bindings to theirs
(:mod:`skill_agent.runtime`). Stop (cancellation): every run is preempted and its result
published, then, shielded, the agent unregisters and the token is undeclared.
"""

from __future__ import annotations

import logging
import socket
from collections.abc import Awaitable, Callable, Mapping
from pathlib import Path

import anyio
import anyio.lowlevel
import msgspec
from anyio.abc import TaskStatus

from meshlink import Answer, IncomingQuery, Mesh, MeshlinkError, check_name
from skill_agent._errors import (
    AgentInternalError,
    BadRequestError,
    ParameterError,
    RunStateError,
    SkillError,
    UnknownRunError,
)
from skill_agent.protocol._codec import decode_request, encode
from skill_agent.protocol._log import LogEntry
from skill_agent.protocol._runs import (
    AgentReply,
    AgentRequest,
    ErrorReply,
    ListRuns,
    ListSkills,
    OkReply,
    PauseRun,
    Reload,
    ResumeRun,
    RunEvent,
    RunFinished,
    RunInfo,
    RunResult,
    RunsReply,
    RunStatus,
    SkillsReply,
    StartRun,
    StopRun,
)
from skill_agent.protocol._skills import ParamState, SkillDescription
from skill_agent.runtime._agent import AgentCore
from skill_agent.runtime._config import AgentConfig
from skill_agent.runtime._event_log import EventLog
from skill_agent.runtime._plugins import SkillRegistry
from skill_agent.runtime._simulated import SimulatedOutcomes
from skill_agent.runtime._wiring import bind_devices, bind_hardware
from wm_store import DeviceSpec, RobotRegistration, SkillSpec, WmClient, WmError, ZenohTransport
from wm_store.ontology import Ontology, core_ontology_path

__all__ = [
    "AgentService",
    "RunEventPublisher",
    "agent_registration",
    "run_agent",
    "serve_agent",
    "simulated_outcomes",
]

_log = logging.getLogger(__name__)
_json = msgspec.json.Encoder()


class AgentService:
    """Requests -> replies for one agent, independent of the transport (unit-testable)."""

    def __init__(
        self,
        core: AgentCore,
        *,
        registry: SkillRegistry | None = None,
        on_reload: Callable[[], Awaitable[None]] | None = None,
    ) -> None:
        self.core = core
        self.registry = registry
        self.on_reload = on_reload
        self._reload_lock = anyio.Lock()

    def skills_reply(self) -> SkillsReply:
        return SkillsReply(
            agent=self.core.name,
            skills=self.core.descriptions(),
            simulated=self.core.simulated is not None,
        )

    def skills_bytes(self, data: bytes) -> tuple[bytes, bool]:
        """The ``skills`` queryable: ``(payload, ok)`` for a query's payload. Empty or an
        encoded ``ListSkills``: the skills; anything else: ``bad_request``. Never raises."""
        if data:
            try:
                request = decode_request(data)
            except msgspec.MsgspecError as e:
                return _error(BadRequestError.code, f"undecodable request: {e}")
            if not isinstance(request, ListSkills):
                name = type(request).__name__
                return _error(
                    BadRequestError.code, f"the skills queryable answers ListSkills, not {name}"
                )
        return encode(self.skills_reply()), True

    async def handle_bytes(self, data: bytes) -> tuple[bytes, bool]:
        """Decode, dispatch, encode. Returns ``(payload, ok)``; never raises an Exception."""
        try:
            request = decode_request(data)
        except msgspec.MsgspecError as e:
            return _error(BadRequestError.code, f"undecodable request: {e}")
        try:
            return encode(await self.handle(request)), True
        except ParameterError as e:
            return _error(e.code, str(e), e.param_states)
        except SkillError as e:
            return _error(e.code, str(e))
        except ValueError as e:  # e.g. a run id that is no valid key segment
            return _error(BadRequestError.code, str(e))
        except Exception as e:
            _log.exception("request %s failed", type(request).__name__)
            return _error(AgentInternalError.code, f"{type(e).__name__}: {e}")

    async def handle(self, request: AgentRequest) -> AgentReply:
        """Answer one request; refusals raise the :mod:`skill_agent` class."""
        core = self.core
        match request:
            case ListSkills():
                return self.skills_reply()
            case StartRun(run_id=run_id):
                if run_id:
                    check_name(run_id, "run id")
                started = await core.start(request)
                if not request.wait:
                    return started
                result = await core.wait(started.run_id)
                return RunFinished(result=result, inferred=started.inferred)
            case StopRun(run_id=run_id):
                result = await core.stop(run_id)
                try:
                    info = core.status(run_id)
                except UnknownRunError:  # forgotten meanwhile: rebuild from the result
                    info = RunInfo(run_id=run_id, skill=result.skill, state="preempted")
                return RunsReply(runs=[msgspec.structs.replace(info, result=result)])
            case PauseRun(run_id=run_id):
                await core.pause(run_id)
                return OkReply(message=f"run {run_id} paused")
            case ResumeRun(run_id=run_id):
                await core.resume(run_id)
                return OkReply(message=f"run {run_id} resumed")
            case RunStatus(run_id=run_id):
                return RunsReply(runs=[core.status(run_id)])
            case ListRuns(active_only=active_only):
                return RunsReply(runs=core.runs(active_only=active_only))
            case Reload():
                return await self._reload()
        raise RunStateError(f"unsupported request {type(request).__name__}")  # pragma: no cover

    async def _reload(self) -> OkReply:
        registry = self.registry
        if registry is None:
            raise RunStateError(f"agent {self.core.name} has no plug-in registry to reload")
        async with self._reload_lock:
            entries = await anyio.to_thread.run_sync(registry.reload)
            self.core.replace_skills(entries)
            if self.on_reload is not None:
                await self.on_reload()
        names = ", ".join(sorted(entries)) or "none"
        _log.warning("agent %s reloaded %d skills: %s", self.core.name, len(entries), names)
        return OkReply(message=f"reloaded {len(entries)} skills: {names}")


class RunEventPublisher:
    """Publishes run events on ``agents/<a>/runs/<run>/progress`` and event-log entries on
    ``agents/<a>/events``, in order, in bursts.

    A Zenoh put after the session was idle for a moment costs far more than puts back to back
    (the wake-up of Zenoh's send path; see docs/benchmarks.md, section Skills, "Why the 3x
    target is not met"). So progress events and log entries wait (at most ``max_delay``
    seconds) and go out together, and a :class:`RunResult` sends everything pending at once,
    itself last, in the loop's next turn (after a ``call``'s reply, which carries the same
    result, has gone out): a short run's seven events cost about one put, and no result waits
    for ``max_delay``.
    :meth:`publish` and :meth:`record` only queue (they are called inline by the core and its
    event log)."""

    def __init__(self, mesh: Mesh, agent: str, *, max_delay: float = 0.002) -> None:
        self.mesh = mesh
        self.agent = agent
        self.max_delay = max_delay
        self._events_key = mesh.keys.agent_events(agent)
        self._pending: list[tuple[str, bytes]] = []
        self._wake = anyio.Event()
        self._result = anyio.Event()  # a result is pending: no waiting for company

    def attach(self, core: AgentCore) -> Callable[[], None]:
        """Publish ``core``'s run events and its event log; returns the detach function."""
        detach_events = core.subscribe(self.publish)
        detach_log = core.events.subscribe(self.record)

        def detach() -> None:
            detach_events()
            detach_log()

        return detach

    def record(self, entry: LogEntry) -> None:
        """Queue an event-log entry (an :class:`EventLog` subscriber, on the loop)."""
        self._pending.append((self._events_key, encode(entry)))
        self._wake.set()

    def publish(self, event: RunEvent) -> None:
        """Queue ``event`` (from the core's subscriber callback, on the loop)."""
        try:
            key = self.mesh.keys.run_progress(self.agent, event.run_id)
        except ValueError as e:
            _log.warning("cannot publish run %r: %s", event.run_id, e)
            return
        self._pending.append((key, encode(event)))
        if isinstance(event, RunResult):
            self._result.set()
        self._wake.set()

    def flush(self) -> None:
        """Put every pending event now, in order (short synchronous Zenoh calls)."""
        batch, self._pending = self._pending, []
        for key, payload in batch:
            try:
                self.mesh.put(key, payload)
            except MeshlinkError as e:
                _log.warning("could not publish on %s: %s", key, e)

    async def run(self) -> None:
        """Flush progress events ``max_delay`` seconds after the first of a burst, and at once
        when a result comes: right after the tasks that were waiting for it (a ``call``'s or a
        stop's reply carries the same result) have taken their turn on the loop."""
        while True:
            await self._wake.wait()
            self._wake = anyio.Event()
            if not self._result.is_set():
                with anyio.move_on_after(self.max_delay):
                    await self._result.wait()
            if self._result.is_set():
                self._result = anyio.Event()
                await anyio.lowlevel.checkpoint()  # let a waiting reply go out first
            self.flush()


def _error(
    code: str, message: str, param_states: Mapping[str, ParamState] | None = None
) -> tuple[bytes, bool]:
    reply = ErrorReply(code=code, message=message, param_states=dict(param_states or {}))
    return encode(reply), False


def agent_registration(
    config: AgentConfig, skills: list[SkillDescription], *, address: str = ""
) -> RobotRegistration:
    """What the agent writes into the world model (agent, robot, devices, skills)."""
    return RobotRegistration(
        agent=config.name,
        agent_type=config.agent_type,
        address=address,
        hostname=socket.gethostname(),
        robot_type=config.robot.type,
        robot_label=config.robot_label,
        robot_properties=dict(config.robot.properties),
        devices=[
            DeviceSpec(type=d.type, label=d.label, properties=d.properties) for d in config.devices
        ],
        skills=[
            SkillSpec(name=d.name, skill_type=d.family, description=_json.encode(d).decode())
            for d in skills
        ],
    )


async def _register(
    wm: WmClient,
    core: AgentCore,
    config: AgentConfig,
    address: str,
    drivers: Mapping[str, object] | None,
) -> None:
    await wm.register_robot(agent_registration(config, core.descriptions(), address=address))
    agents = wm.resolve_element(type="Agent", label=config.name)
    controlled = [r.object for a in agents for r in wm.query_relation(a.id, "controls")]
    core.robot = controlled[0] if controlled else None  # its hasA devices are the hardware
    if drivers is not None:  # in place: the runs' environment holds this very dict
        core.devices.clear()
        core.devices.update(bind_devices(wm, config.device_labels, drivers, robot=core.robot))
    core.hardware.update(bind_hardware(wm, config.hardware, robot=core.robot))


async def serve_agent(
    mesh: Mesh,
    core: AgentCore,
    *,
    config: AgentConfig,
    wm: WmClient,
    registry: SkillRegistry | None = None,
    drivers: Mapping[str, object] | None = None,
    unregister_timeout: float = 5.0,
    task_status: TaskStatus[None] = anyio.TASK_STATUS_IGNORED,
) -> None:
    """Run ``core`` and serve it on ``mesh`` until cancelled (see the module docstring);
    ``started`` once the agent is registered, wired and reachable. ``drivers``: device
    drivers by world-model label; given, they replace ``core.devices`` (bound by label).

    Raises:
        WmError: the registration was refused or the store is unreachable.
        WiringError: a device label of the configuration names no element or several.
    """
    keys, name = mesh.keys, core.name
    address = keys.agent(name)

    async def reregister() -> None:
        await _register(wm, core, config, address, drivers)

    service = AgentService(core, registry=registry, on_reload=reregister)

    async def rpc(query: IncomingQuery) -> list[Answer]:
        data, ok = await service.handle_bytes(query.payload or b"")
        return [Answer(key=keys.agent_rpc(name), payload=data, ok=ok)]

    async def skills(query: IncomingQuery) -> list[Answer]:
        data, ok = service.skills_bytes(query.payload or b"")
        return [Answer(key=keys.agent_skills(name), payload=data, ok=ok)]

    publisher = RunEventPublisher(mesh, name)
    unsubscribe = publisher.attach(core)
    token = None
    try:
        async with anyio.create_task_group() as tg:
            tg.start_soon(publisher.run)
            await tg.start(core.run)
            await tg.start(mesh.serve, keys.agent_skills(name), skills)
            await tg.start(mesh.serve, keys.agent_rpc(name), rpc)
            token = mesh.declare_token(address)
            await reregister()
            _log.warning(
                "agent %s ready on mesh %r: %d skills (%s)%s",
                name,
                keys.mesh,
                len(core.descriptions()),
                ", ".join(d.name for d in core.descriptions()),
                ", simulated outcomes" if core.simulated is not None else "",
            )
            task_status.started()
    finally:
        unsubscribe()
        publisher.flush()  # what runs preempted at shutdown left pending, their results too
        with anyio.CancelScope(shield=True):
            if token is not None:
                with anyio.move_on_after(unregister_timeout):
                    try:
                        await wm.unregister_robot(name)
                    except WmError as e:
                        _log.warning("agent %s could not unregister: %s", name, e)
                token.undeclare()
        _log.info("agent %s stopped", name)


def _ontology(config: AgentConfig) -> Ontology:
    if not config.ontology:
        return Ontology.default()
    return Ontology.load(core_ontology_path(), *(Path(p) for p in config.ontology))


def simulated_outcomes(config: AgentConfig, *, force: bool = False) -> SimulatedOutcomes | None:
    """The config's simulated-outcome settings, or None when the mode is off."""
    sim = config.simulation
    if not (force or sim.enabled):
        return None
    default = 1.0 if sim.default is None else sim.default
    return SimulatedOutcomes(sim.probabilities, default, sim.seed, time_scale=sim.time_scale)


async def run_agent(
    mesh: Mesh,
    config: AgentConfig,
    *,
    simulate: bool = False,
    drivers: Mapping[str, object] | None = None,
    wm_timeout: float = 5.0,
    task_status: TaskStatus[None] = anyio.TASK_STATUS_IGNORED,
) -> None:
    """Everything ``skimesh agent`` does: join the world model, load and check the skills,
    build the core and serve it until cancelled. ``simulate`` forces simulated outcomes.
    ``drivers``: device drivers by world-model label (``driver.name``), bound to the agent's
    devices and hardware bindings by label (see the module doc); None: no drivers.

    Raises:
        SkillLoadError: a skill or the config does not load (WiringError: a device label
            names no element). WmError: no world model.
    """
    ontology = await anyio.to_thread.run_sync(_ontology, config)
    transport = ZenohTransport(mesh)
    async with WmClient.connect(transport, ontology, author=config.name, timeout=wm_timeout) as wm:
        registry = SkillRegistry.from_config(config, wm.ontology, context={"mesh": mesh})
        entries = await anyio.to_thread.run_sync(registry.load)
        config.check_skill_names(entries)
        log_path = Path(config.event_log) if config.event_log else None
        with EventLog(log_path) as events:
            core = AgentCore(
                name=config.name,
                wm=wm,
                skills=entries,
                events=events,
                simulated=simulated_outcomes(config, force=simulate),
                preempt_timeout=config.preempt_timeout,
                registry=registry.conditions,
            )
            await serve_agent(
                mesh,
                core,
                config=config,
                wm=wm,
                registry=registry,
                drivers=drivers,
                task_status=task_status,
            )
