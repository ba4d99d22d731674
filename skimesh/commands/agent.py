"""``skimesh agent`` (serve a skill agent) and the skill-layer CLI: ``skimesh agents``,
``skimesh skills [AGENT]``, ``skimesh run AGENT SKILL key=value...``, ``skimesh reload AGENT``,
``skimesh stop AGENT RUN``, and (``_runs``) ``skimesh runs [AGENT] [RUN] [--follow]``,
``skimesh pause AGENT RUN`` and ``skimesh resume AGENT RUN``.

``skimesh run`` starts a skill from a plain command line and streams its progress until the
result (SkiROS2 #42). Exit codes: 0 the run succeeded, 1 it failed, 2 the agent refused it
(unknown skill, bad parameters, busy device, false pre-condition), 3 the agent could not be
reached, disappeared, or no result came within ``--deadline``; 130 interrupted: Ctrl-C (or
SIGTERM) stops the run on the agent (its ``on_preempt`` runs) before the command exits.
"""

from __future__ import annotations

import argparse
import contextlib
import json
import logging
import sys
from collections.abc import Awaitable, Callable, Mapping, Sequence
from contextlib import AsyncExitStack
from pathlib import Path
from typing import TYPE_CHECKING

import anyio
import msgspec

from meshlink import Mesh, MeshlinkError, add_mesh_arguments
from skill_agent import AgentTransportError, SkillError
from skill_agent.client import AgentClient, find_skills, list_agents
from skill_agent.protocol import RunEvent, RunResult, SkillDescription
from wm_store import WmClient, WmError, ZenohTransport
from wm_store.ontology import TYPED_KINDS, did_you_mean
from wm_store.protocol import Value

from ..errors import Exit, SkimeshError, complain
from ..runtime import run_service
from . import _runs as runs_command
from ._connect import mesh_session, store_answers
from ._run_view import RunLines, with_output
from ._store_reads import registered_agents
from ._table import print_table

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
    agents.set_defaults(func=lambda a: _client(a, _agents))

    skills = sub.add_parser("skills", help="list the skills of one agent or of all agents")
    skills.add_argument("agent", nargs="?", help="only this agent")
    _client_arguments(skills)
    skills.set_defaults(func=lambda a: _client(a, _skills))

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
    run.set_defaults(func=lambda a: _client(a, _run))

    reload = sub.add_parser(
        "reload", help="re-import an agent's skill plug-ins (runs in flight keep their code)"
    )
    reload.add_argument("agent", help="the agent whose skills are loaded again")
    _client_arguments(reload)
    reload.set_defaults(func=lambda a: _client(a, _reload))

    stop = sub.add_parser("stop", help="stop a run (the skill brings its hardware to safety)")
    stop.add_argument("agent", help="the agent running it")
    stop.add_argument("run_id", help="the run's id (printed by `skimesh run`)")
    _client_arguments(stop)
    stop.set_defaults(func=lambda a: _client(a, _stop))

    runs_command.add_parsers(
        sub,
        client_arguments=_client_arguments,
        client=_client,
        print_event=_print_event,
        print_json=_print_json,
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
                mesh = await stack.enter_async_context(mesh_session(args))
                who = "agent " + ", ".join(c.name for c in configs)
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


# --------------------------------------------------------------------------- clients


def _client(args: argparse.Namespace, body: Callable[[argparse.Namespace], Awaitable[int]]) -> int:
    interrupted: list[bool] = []

    async def main() -> int:
        try:
            return await body(args)
        except anyio.get_cancelled_exc_class():  # SIGINT / SIGTERM: a run in flight is stopped
            interrupted.append(True)
            raise
        except AgentTransportError as e:
            said, code = await _not_alive(args) or (str(e), EXIT_UNREACHABLE)
            complain(args, said)
            return code
        except TimeoutError:
            deadline = getattr(args, "deadline", None)
            within = f"--deadline {deadline:g} s" if deadline else f"--timeout {args.timeout:g} s"
            complain(args, f"no result within {within} (run stopped)")
            return EXIT_UNREACHABLE
        except SkillError as e:
            complain(args, str(e))
            return EXIT_REFUSED
        except MeshlinkError as e:
            complain(args, str(e))
            return EXIT_UNREACHABLE

    code = run_service(main)
    if interrupted:
        print("interrupted (a run in flight was stopped)", file=sys.stderr)
        return EXIT_INTERRUPTED
    return code


async def _not_alive(args: argparse.Namespace) -> tuple[str, Exit] | None:
    """For an agent that did not answer, at once: "no agent X" naming the closest names
    (refused: the world model knows no such agent), or "agent X is not alive" (unreachable:
    it is registered, its process is gone); None when X is alive or the mesh cannot tell."""
    name = getattr(args, "agent", None)
    if not name:
        return None
    registered: dict[str, dict[str, object]] | None = None
    try:
        async with mesh_session(args) as mesh:
            alive = await list_agents(mesh, timeout=min(args.timeout, 2.0))
            if name not in alive:
                with contextlib.suppress(WmError):
                    registered = await registered_agents(mesh, timeout=min(args.timeout, 2.0))
    except MeshlinkError:
        return None
    if name in alive:
        return None
    where = f"mesh {args.mesh!r}"
    listed = f" (alive: {', '.join(alive)})" if alive else " (none is alive)"
    if registered is not None and name not in registered:
        hint = did_you_mean(name, sorted(set(alive) | set(registered))).rstrip(".")
        return f"no agent {name!r} on {where}{hint}{listed}", Exit.REFUSED
    if not alive:
        return f"no agent is alive on {where} (is `skimesh agent` running there?)", EXIT_UNREACHABLE
    return f"agent {name!r} is not alive on {where}{listed}", EXIT_UNREACHABLE


def _print_json(obj: object) -> None:
    sys.stdout.write(msgspec.json.encode(obj).decode() + "\n")
    sys.stdout.flush()


async def _agents(args: argparse.Namespace) -> int:
    async with mesh_session(args) as mesh:
        alive = set(await list_agents(mesh, timeout=args.timeout))
        registered: dict[str, dict[str, object]] = {}
        reached = True
        try:  # three reads from the store: no replica, no ontology to load (start-up time)
            registered = await registered_agents(mesh, timeout=args.timeout)
        except WmError as e:
            reached = False
            print(f"warning: world model unreachable ({e}); liveliness only", file=sys.stderr)
    names = sorted(alive | set(registered))
    if not names:
        where = f"mesh {mesh.keys.mesh!r}"
        if not reached:
            print(f"skimesh agents: no agent alive on {where}, and no world model", file=sys.stderr)
            return EXIT_UNREACHABLE
        print(f"skimesh agents: no agent on {where}", file=sys.stderr)
        return EXIT_FAILED
    rows = [{"agent": n, "alive": n in alive, **registered.get(n, {})} for n in names]
    if args.json:
        _print_json(rows)
    else:
        head = ("AGENT", "ALIVE", "AVAILABLE", "ROBOT", "SKILLS", "ELEMENT")
        cells = [
            [
                str(r.get(k, "-"))
                for k in ("agent", "alive", "available", "robot", "skills", "element")
            ]
            for r in rows
        ]
        print_table(head, cells)
    return 0


def _param_text(desc: SkillDescription) -> str:
    parts = []
    for p in desc.parameters:
        text = f"{p.name}:{p.type}"
        if p.kind != "online":
            text += f"[{p.kind}]"
        if p.default is not None:
            text += f"={json.dumps(msgspec.to_builtins(p.default))}"
        parts.append(text)
    return " ".join(parts)


async def _skills(args: argparse.Namespace) -> int:
    async with mesh_session(args) as mesh:
        if args.agent:
            replies = {
                args.agent: await AgentClient(mesh, args.agent, timeout=args.timeout).skills_reply()
            }
        else:
            replies = await find_skills(mesh, timeout=args.timeout)
    if not replies:
        print(f"skimesh skills: no agent answered on mesh {args.mesh!r}", file=sys.stderr)
        return EXIT_UNREACHABLE
    if args.json:
        _print_json({agent: reply.skills for agent, reply in replies.items()})
        return 0
    rows = [
        [agent, d.name, d.family, _param_text(d), (d.doc.strip().splitlines() or [""])[0]]
        for agent, reply in replies.items()
        for d in reply.skills
    ]
    print_table(("AGENT", "SKILL", "TYPE", "PARAMETERS", "DOC"), rows)
    return 0


def parse_params(pairs: Sequence[str], desc: SkillDescription | None) -> dict[str, Value]:
    """``key=value`` words -> parameter values, converted by the parameter's declared type
    (numbers, booleans, typed values as JSON; element ids and strings as given)."""
    kinds = {p.name: p.type for p in desc.parameters} if desc is not None else {}
    values: dict[str, Value] = {}
    for pair in pairs:
        key, sep, raw = pair.partition("=")
        if not sep or not key:
            raise SkillError(f"parameters are KEY=VALUE, not {pair!r}")
        values[key] = _convert(raw, kinds.get(key, "any"), key)
    return values


def _convert(raw: str, kind: str, key: str) -> Value:
    try:
        if kind == "float":
            return float(raw)
        if kind == "int":
            return int(raw)
        if kind == "bool":
            if raw.lower() not in ("true", "false", "1", "0", "yes", "no"):
                raise ValueError(raw)
            return raw.lower() in ("true", "1", "yes")
        if kind in TYPED_KINDS:
            return msgspec.json.decode(raw, type=TYPED_KINDS[kind])
        if kind in ("any", "list", "Size"):
            decoded: Value = msgspec.json.decode(raw, type=Value)
            return decoded
    except (ValueError, msgspec.MsgspecError) as e:
        if kind in ("any", "list", "Size"):
            return raw  # not JSON: a plain string (the agent checks the kind)
        raise SkillError(f"parameter {key}: {raw!r} is no valid {kind} ({e})") from None
    return raw  # str, or an element id


def _print_event(event: RunEvent) -> None:
    RunLines()(event)


async def _run(args: argparse.Namespace) -> int:
    async with (
        mesh_session(args) as mesh,
        AgentClient(mesh, args.agent, timeout=args.timeout) as client,
    ):
        skills = {d.name: d for d in await client.skills()}
        params = parse_params(args.params, skills.get(args.skill))

        async def run(on_event: Callable[[RunEvent], None]) -> RunResult:
            return await client.run(
                args.skill,
                params,
                queue=args.queue,
                simulate=args.simulate,
                timeout=args.run_timeout,
                deadline=args.deadline,
                on_event=on_event,
                author="cli",
            )

        json_out = _print_json if args.json else None
        result = await with_output(run, agent=args.agent, skill=args.skill, json_out=json_out)
    return 0 if result.success else EXIT_FAILED


async def _reload(args: argparse.Namespace) -> int:
    async with mesh_session(args) as mesh:
        print(await AgentClient(mesh, args.agent, timeout=args.timeout).reload())
    return 0


async def _stop(args: argparse.Namespace) -> int:
    async with mesh_session(args) as mesh:
        result = await AgentClient(mesh, args.agent, timeout=args.timeout).stop(args.run_id)
    if args.json:
        _print_json(result)
    else:
        _print_event(result)
    return 0
