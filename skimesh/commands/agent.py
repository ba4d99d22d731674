"""``skimesh agent`` (serve skill agents) and the parsers of the skill-layer CLI (their bodies
in ``_agent_clients`` and ``_runs``): ``skimesh agents``, ``skimesh skills [AGENT]``, ``skimesh
run AGENT SKILL key=value...``, ``skimesh reload AGENT``, ``skimesh stop AGENT RUN``, ``skimesh
runs [AGENT] [RUN] [--follow]``, ``skimesh pause AGENT RUN`` and ``skimesh resume AGENT RUN``.

``skimesh run`` starts a skill from a plain command line and streams its progress until the
result (SkiROS2 #42). Exit codes: 0 the run succeeded, 1 it failed, 2 the agent refused it
(unknown skill, bad parameters, busy device, false pre-condition), 3 the agent could not be
reached, disappeared, or no result came within ``--deadline``; 130 interrupted: Ctrl-C (or
SIGTERM) stops the run on the agent (its ``on_preempt`` runs) before the command exits.
"""

from __future__ import annotations

import argparse
import logging
import sys
from collections.abc import Mapping, Sequence
from contextlib import AsyncExitStack
from pathlib import Path
from typing import TYPE_CHECKING

import anyio

from meshlink import Mesh, MeshlinkError, add_mesh_arguments
from skill_agent import SkillError
from wm_store import WmClient, WmError, ZenohTransport

from ..errors import Exit, SkimeshError
from ..runtime import run_service
from . import _agent_clients as clients
from . import _runs as runs_command
from ._agent_clients import parse_params
from ._connect import service_mesh, store_answers

if TYPE_CHECKING:  # the runtime and server load only to serve an agent (start-up time)
    from skill_agent.runtime import AgentConfig

__all__ = ["add_parser", "parse_params", "scenario_config_path"]

_log = logging.getLogger("skimesh.agent")
Sub = argparse._SubParsersAction  # argparse keeps the sub-parsers action class private
EXIT_FAILED, EXIT_REFUSED, EXIT_UNREACHABLE = Exit.FAILED, Exit.REFUSED, Exit.UNREACHABLE
EXIT_INTERRUPTED = Exit.INTERRUPTED


def add_parser(sub: Sub[argparse.ArgumentParser]) -> None:
    """Add ``agent``, ``agents``, ``skills``, ``run``, ``reload``, ``stop``, ``runs``,
    ``pause`` and ``resume``."""
    p = sub.add_parser(
        "agent",
        help="run the skill agent of a robot or smart device (or several, in one process)",
        description="Serve a skill agent: register it in the world model, answer skill "
        "requests on agents/NAME/rpc, publish run progress. Several agents (--robot or "
        "--agent-config repeated; --robot all: every agent the scenario names) share one "
        "process and one Zenoh session, and load their skills side by side. Stops cleanly on "
        "Ctrl-C / SIGTERM.",
    )
    add_mesh_arguments(p, config_type=_zenoh_config_file)
    where = p.add_mutually_exclusive_group(required=True)
    where.add_argument(
        "--scenario",
        help="with --robot: the agent config the scenario names for that robot or appliance "
        "(a scenario name under configs/scenarios or a scenario file)",
    )
    where.add_argument(
        "--agent-config",
        action="append",
        metavar="FILE",
        help="an agent config file (TOML) instead of --scenario (repeatable)",
    )
    p.add_argument(
        "--robot",
        action="append",
        help="the robot or appliance (or agent name) of --scenario (repeatable; 'all': every "
        "agent the scenario names)",
    )
    p.add_argument("--simulate", action="store_true", help="simulated-outcome mode (no hardware)")
    p.add_argument(
        "--devices",
        choices=("zenoh", "none"),
        help="device drivers: 'zenoh' proxies of the devices `skimesh sim` (or real hardware) "
        "serves on the mesh, bound by label (default); 'none' (default with --simulate)",
    )
    p.add_argument("--device-timeout", type=float, default=2.0, help="wait for device servers (s)")
    p.add_argument("--timeout", type=float, default=5.0, help="world-model request timeout (s)")
    p.set_defaults(func=_serve)

    agents = sub.add_parser("agents", help="list skill agents: alive (liveliness) and in the WM")
    _client_arguments(agents)
    agents.set_defaults(func=lambda a: clients.client(a, clients.agents))

    skills = sub.add_parser("skills", help="list the skills of one agent or of all agents")
    skills.add_argument("agent", nargs="?", help="only this agent")
    _client_arguments(skills)
    skills.set_defaults(func=lambda a: clients.client(a, clients.skills))

    run = sub.add_parser(
        "run",
        help="run a skill on an agent and stream its progress until the result",
        description="Start SKILL on AGENT with key=value parameters (element parameters take "
        'element ids; typed values as JSON, e.g. pose=\'{"position": {"x": 1}}\'). Exit '
        "codes: 0 succeeded, 1 failed, 2 refused, 3 agent unreachable or lost / deadline.",
    )
    run.add_argument("agent", help="the agent that runs it (see `skimesh agents`)")
    run.add_argument("skill", help="the skill's name (see `skimesh skills AGENT`)")
    run.add_argument(
        "params",
        nargs="*",
        metavar="KEY=VALUE",
        help="parameters, e.g. object=Gear-1 (element ids as given; numbers, booleans and typed "
        "values as JSON, by the parameter's declared type)",
    )
    run.add_argument("--queue", action="store_true", help="wait for busy devices, not refuse")
    run.add_argument("--simulate", action="store_true", help="simulated outcome for this run")
    run.add_argument("--run-timeout", type=float, help="the run's own time limit (s)")
    run.add_argument("--deadline", type=float, default=600.0, help="give up after (s)")
    _client_arguments(run)
    run.set_defaults(func=lambda a: clients.client(a, clients.run))

    reload = sub.add_parser(
        "reload", help="re-import an agent's skill plug-ins (runs in flight keep their code)"
    )
    reload.add_argument("agent", help="the agent whose skills are loaded again")
    _client_arguments(reload)
    reload.set_defaults(func=lambda a: clients.client(a, clients.reload))

    stop = sub.add_parser("stop", help="stop a run (the skill brings its hardware to safety)")
    stop.add_argument("agent", help="the agent running it")
    stop.add_argument("run_id", help="the run's id (printed by `skimesh run`)")
    _client_arguments(stop)
    stop.set_defaults(func=lambda a: clients.client(a, clients.stop))

    runs_command.add_parsers(
        sub,
        client_arguments=_client_arguments,
        client=clients.client,
        print_event=clients.print_event,
        print_json=clients.print_json,
    )


def _zenoh_config_file(path: str) -> str:
    """``--config`` is the Zenoh JSON5 file, as for every command; an agent TOML there
    (the agent's own file) is a usage error naming ``--agent-config``."""
    if path.lower().endswith(".toml"):
        raise argparse.ArgumentTypeError(
            f"{path} is TOML, but --config takes a Zenoh JSON5 file; give the agent's config "
            f"with --agent-config {path} (or use --scenario S --robot R)"
        )
    return path


def _client_arguments(p: argparse.ArgumentParser) -> None:
    add_mesh_arguments(p)
    p.add_argument("--timeout", type=float, default=5.0, help="request timeout in seconds")
    p.add_argument("--json", action="store_true", help="machine-readable output")


# --------------------------------------------------------------------------- agent


def scenario_config_path(scenario: str, robot: str) -> Path:
    """The agent config the scenario file names for ``robot`` (a robot name, an appliance
    label, or the name inside one of its agent configs: ``Scenario.agents``), or
    FileNotFoundError listing what the scenario has."""
    from scenario import ScenarioError, load_scenario
    from skill_agent.runtime import load_config

    from .sim import scenario_file

    try:
        agents = load_scenario(scenario_file(scenario)).agents
    except ScenarioError as e:
        raise FileNotFoundError(str(e)) from None
    if robot in agents:
        return Path(agents[robot])
    for owner, path in agents.items():
        try:
            if load_config(path).name == robot:
                return Path(path)
        except SkillError as e:
            _log.warning("agent config of %s: %s", owner, e)
    names = ", ".join(sorted(agents)) or "none"
    raise FileNotFoundError(f"scenario {scenario!r} names no agent for {robot!r}; it has: {names}")


def _load(args: argparse.Namespace) -> list[AgentConfig]:
    from skill_agent.runtime import load_config

    if args.agent_config:
        configs = [load_config(path) for path in args.agent_config]
    else:
        if not args.robot:
            raise SkillError("--scenario needs --robot (repeatable; 'all': every agent)")
        robots = list(args.robot)
        if robots == ["all"]:
            robots = sorted(_scenario_agents(args.scenario))
        configs = [load_config(scenario_config_path(args.scenario, r)) for r in robots]
    names = [c.name for c in configs]
    twice = sorted({n for n in names if names.count(n) > 1})
    if twice:
        raise SkillError(f"agent {', '.join(twice)} given twice: one process serves each once")
    return configs


def _scenario_agents(scenario: str) -> dict[str, str]:
    from scenario import ScenarioError, load_scenario

    from .sim import scenario_file

    try:
        return load_scenario(scenario_file(scenario)).agents
    except ScenarioError as e:
        raise FileNotFoundError(str(e)) from None


def _serve(args: argparse.Namespace) -> int:
    from skill_agent.server import run_agent

    try:
        configs = _load(args)
    except (SkillError, FileNotFoundError) as e:
        print(f"skimesh agent: {e}", file=sys.stderr)
        return EXIT_REFUSED

    remote = (args.devices or ("none" if args.simulate else "zenoh")) == "zenoh"

    async def serve(mesh: Mesh, config: AgentConfig, wm: WmClient | None) -> None:
        try:
            drivers = await _remote_drivers(mesh, config, args.device_timeout) if remote else None

            async def served(labels: Sequence[str]) -> Mapping[str, object]:
                from device_drivers.remote import connect_devices

                found = await connect_devices(mesh, timeout=args.device_timeout)
                return {d.name: d for d in found.values() if d.name in labels}

            await run_agent(
                mesh,
                config,
                simulate=args.simulate,
                drivers=drivers,
                find_devices=served if remote else None,
                wm_timeout=args.timeout,
                wm=wm,
            )
        except (SkillError, WmError, MeshlinkError) as e:
            raise _AgentFailed(config.name, e) from e

    async def main() -> int:
        try:
            async with AsyncExitStack() as stack:
                who = "agent " + ", ".join(c.name for c in configs)
                mesh = await stack.enter_async_context(service_mesh(args, who))
                await store_answers(mesh, who, timeout=args.timeout)
                wm = None
                if len(configs) > 1:  # the agents of one process share one replica
                    transport = ZenohTransport(mesh)
                    wm = await stack.enter_async_context(
                        WmClient.connect(transport, timeout=args.timeout)
                    )
                async with anyio.create_task_group() as tg:
                    for config in configs:
                        tg.start_soon(serve, mesh, config, wm)
        except (WmError, MeshlinkError) as e:  # the session itself
            print(f"skimesh agent: {e}", file=sys.stderr)
            return EXIT_UNREACHABLE
        except BaseExceptionGroup as group:
            failed = [e for e in group.exceptions if isinstance(e, _AgentFailed)]
            if len(failed) != len(group.exceptions):
                raise
            for failure in failed:
                print(f"skimesh agent {failure.agent}: {failure.cause}", file=sys.stderr)
            refused = any(isinstance(f.cause, SkillError) for f in failed)
            return EXIT_REFUSED if refused else EXIT_UNREACHABLE
        return 0

    return run_service(main)


class _AgentFailed(SkimeshError):
    """One agent of the process stopped with an error the user can act on."""

    def __init__(self, agent: str, cause: Exception) -> None:
        super().__init__(f"{agent}: {cause}")
        self.agent, self.cause = agent, cause


async def _remote_drivers(mesh: Mesh, config: AgentConfig, timeout: float) -> dict[str, object]:
    """Zenoh proxies of the devices served on the mesh, by label (those this agent uses)."""
    from device_drivers.remote import connect_devices

    found = {d.name: d for d in (await connect_devices(mesh, timeout=timeout)).values()}
    mine: dict[str, object] = {
        label: found[label] for label in config.device_labels if label in found
    }
    missing = [d.label for d in config.devices if d.label not in found]
    if missing:
        _log.warning(
            "agent %s: no device server answered for %s (is `skimesh sim` running?); the "
            "agent binds them once they are served, skills that need them fail until then",
            config.name,
            ", ".join(missing),
        )
    return mine
