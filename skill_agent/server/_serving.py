"""Serving an agent: registration in the world model, queryables, token, publisher;
``skimesh agent`` end to end."""

from __future__ import annotations

import logging
import socket
from collections.abc import AsyncIterator, Awaitable, Callable, Mapping, Sequence
from contextlib import asynccontextmanager
from pathlib import Path

import anyio
import msgspec
from anyio.abc import TaskStatus

from meshlink import Backoff, Mesh
from skill_agent._errors import SkillLoadError
from skill_agent.protocol._skills import SkillDescription
from skill_agent.runtime._agent import AgentCore
from skill_agent.runtime._config import AgentConfig
from skill_agent.runtime._event_log import EventLog
from skill_agent.runtime._plugins import SkillRegistry
from skill_agent.runtime._simulated import SimulatedOutcomes
from skill_agent.runtime._wiring import (
    WiringError,
    bind_devices,
    bind_hardware,
    element_for_label,
)
from skill_agent.server._publisher import RunEventPublisher
from skill_agent.server._service import AgentService
from wm_store import DeviceSpec, RobotRegistration, SkillSpec, WmClient, WmError, ZenohTransport

__all__ = [
    "FindDevices",
    "agent_registration",
    "run_agent",
    "serve_agent",
    "simulated_outcomes",
]

FindDevices = Callable[[Sequence[str]], Awaitable[Mapping[str, object]]]
"""Drivers of those of the given device labels that are served now (the others left out)."""

LATE_POLL_MAX = 10.0
"""Seconds between two looks for devices not served yet, at most (from 1 s, doubling)."""

_log = logging.getLogger(__name__)
_json = msgspec.json.Encoder()


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
    # the bindings published with the skills (their hardware defaults) are the ones runs use:
    # those whose devices are there already go with the first registration, the rest (the
    # robot's own devices, just registered) with a second one
    published = _bound_already(wm, config.hardware)
    core.hardware.update(published)
    await wm.register_robot(agent_registration(config, core.descriptions(), address=address))
    agents = wm.resolve_element(type="Agent", label=config.name)
    controlled = [r.object for a in agents for r in wm.query_relation(a.id, "controls")]
    core.robot = controlled[0] if controlled else None  # its hasA devices are the hardware
    if drivers is not None:  # in place: the runs' environment holds this very dict
        core.devices.clear()
        core.devices.update(bind_devices(wm, config.device_labels, drivers, robot=core.robot))
    bound = bind_hardware(wm, config.hardware, robot=core.robot)
    core.hardware.update(bound)
    if bound != published:
        await wm.register_robot(agent_registration(config, core.descriptions(), address=address))


def _bound_already(wm: WmClient, hardware: Mapping[str, str]) -> dict[str, str]:
    """Parameter -> device id of the configured bindings whose device is an element now."""
    found = {}
    for param, label in hardware.items():
        try:
            found[param] = element_for_label(wm, label)
        except WiringError:
            continue
    return found


async def serve_agent(
    mesh: Mesh,
    core: AgentCore,
    *,
    config: AgentConfig,
    wm: WmClient,
    registry: SkillRegistry | None = None,
    drivers: Mapping[str, object] | None = None,
    find_devices: FindDevices | None = None,
    unregister_timeout: float = 5.0,
    task_status: TaskStatus[None] = anyio.TASK_STATUS_IGNORED,
) -> None:
    """Run ``core`` and serve it on ``mesh`` until cancelled (see the module docstring);
    ``started`` once the agent is registered, wired and reachable. ``drivers``: device
    drivers by world-model label; given, they replace ``core.devices`` (bound by label).
    ``find_devices``: where devices of the config have no driver yet (an agent started before
    the simulator or a device server), look for them now and then (every 1 s, doubling up to
    :data:`LATE_POLL_MAX`) and bind each one found, until none is missing.

    Raises:
        WmError: the registration was refused or the store is unreachable.
        WiringError: a device label of the configuration names no element or several.
    """
    keys, name = mesh.keys, core.name
    address = keys.agent(name)
    drivers = None if drivers is None else dict(drivers)  # late devices join this one

    async def reregister() -> None:
        await _register(wm, core, config, address, drivers)

    async def teach() -> None:
        if registry is not None:
            await teach_terms(wm, config, registry)

    service = AgentService(core, registry=registry, on_reload=reregister, before_reload=teach)

    publisher = RunEventPublisher(mesh, name)
    unsubscribe = publisher.attach(core)
    token = None
    try:
        async with anyio.create_task_group() as tg:
            tg.start_soon(publisher.run)
            await tg.start(core.run)
            skills_key, rpc_key = keys.agent_skills(name), keys.agent_rpc(name)
            await tg.start(mesh.serve, skills_key, service.skills.serve_on(skills_key))
            await tg.start(mesh.serve, rpc_key, service.rpc.serve_on(rpc_key))
            token = mesh.declare_token(address)
            await reregister()
            _log.info(
                "agent %s ready on mesh %r: %d skills (%s)%s",
                name,
                keys.mesh,
                len(core.descriptions()),
                ", ".join(d.name for d in core.descriptions()),
                ", simulated outcomes" if core.simulated is not None else "",
            )
            if drivers is not None and find_devices is not None:
                tg.start_soon(_late_devices, core, config, wm, drivers, find_devices)
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
                        _log.info(  # not a fault: the store follows the token (presence)
                            "agent %s not unregistered (%s); the store marks it unavailable "
                            "when its liveliness token goes",
                            name,
                            e,
                        )
                token.undeclare()
        _log.info("agent %s stopped", name)


async def _late_devices(
    core: AgentCore,
    config: AgentConfig,
    wm: WmClient,
    drivers: dict[str, object],
    find: FindDevices,
) -> None:
    """Bind the devices of ``config`` served after the agent started (see :func:`serve_agent`)."""
    expected = list(dict.fromkeys([*(d.label for d in config.devices), *config.hardware.values()]))
    backoff = Backoff(1.0, LATE_POLL_MAX)
    while missing := [label for label in expected if label not in drivers]:
        await backoff.wait()
        found = {k: v for k, v in (await find(missing)).items() if k in missing}
        if not found:
            continue
        try:
            bound = bind_devices(wm, found, found, robot=core.robot)
        except WiringError as e:
            _log.warning("agent %s: a device served now cannot be bound: %s", core.name, e)
            return
        drivers.update(found)
        core.devices.update(bound)
        _log.info("agent %s: devices served now: %s", core.name, ", ".join(sorted(found)))


def _terms(config: AgentConfig, registry: SkillRegistry) -> list[tuple[str, str]]:
    """(source, Turtle) of the agent's ``ontology`` files, then of the files its skills ship."""
    paths = [Path(p) for p in config.ontology]
    paths += [p for p in registry.shipped_terms() if p not in paths]
    out = []
    for path in paths:
        try:
            out.append((f"{config.name}: {path.name}", path.read_text(encoding="utf-8")))
        except (OSError, UnicodeDecodeError) as exc:
            raise SkillLoadError(f"agent {config.name!r}: ontology file {path}: {exc}") from exc
    return out


async def teach_terms(wm: WmClient, config: AgentConfig, registry: SkillRegistry) -> None:
    """Teach the world model the agent's and its skills' ontology terms (known terms change
    nothing), so every process of the mesh checks against them; then the registry checks the
    skills against the result."""
    for source, text in await anyio.to_thread.run_sync(_terms, config, registry):
        try:
            await wm.teach(text, source=source)
        except WmError as exc:
            raise SkillLoadError(f"agent {config.name!r}: {exc}") from exc
    registry.ontology = wm.ontology


@asynccontextmanager
async def _client(
    mesh: Mesh, config: AgentConfig, shared: WmClient | None, timeout: float
) -> AsyncIterator[WmClient]:
    if shared is not None:
        yield shared.with_author(config.name)
        return
    async with WmClient.connect(ZenohTransport(mesh), author=config.name, timeout=timeout) as wm:
        yield wm


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
    find_devices: FindDevices | None = None,
    wm_timeout: float = 5.0,
    wm: WmClient | None = None,
    task_status: TaskStatus[None] = anyio.TASK_STATUS_IGNORED,
) -> None:
    """Everything ``skimesh agent`` does: join the world model, load and check the skills,
    build the core and serve it until cancelled. ``simulate`` forces simulated outcomes.
    ``drivers``: device drivers by world-model label (``driver.name``), bound to the agent's
    devices and hardware bindings by label (see the module doc); None: no drivers.
    ``find_devices``: looks for the devices still without a driver (:func:`serve_agent`).
    ``wm``: a connected client of this process whose replica the agent shares (it writes as
    itself through :meth:`~wm_store.WmClient.with_author`): the agents of one process then
    receive, decode and apply each world-model change once, not once each: ``async with
    WmClient.connect(ZenohTransport(mesh)) as wm:``, then ``run_agent(..., wm=wm)`` for each
    agent inside the block (the replica follows the store while it is open); None: a
    replica of the agent's own.

    Raises:
        SkillLoadError: a skill or the config does not load (WiringError: a device label
            names no element). WmError: no world model.
    """
    async with _client(mesh, config, wm, wm_timeout) as wm:
        registry = SkillRegistry.from_config(config, wm.ontology, context={"mesh": mesh})
        await teach_terms(wm, config, registry)
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
                find_devices=find_devices,
                task_status=task_status,
            )
