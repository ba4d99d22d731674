"""The skill-layer client commands: ``skimesh agents``, ``skills [AGENT]``, ``run AGENT SKILL
key=value...``, ``reload AGENT`` and ``stop AGENT RUN`` (their parsers are in ``agent``).

:func:`client` runs one of them with the errors of the exit-code table: an agent that does not
answer is named against the live and the registered agents at once (unknown: refused; known and
gone: unreachable)."""

from __future__ import annotations

import argparse
import contextlib
import json
import sys
from collections.abc import Awaitable, Callable, Sequence

import anyio
import msgspec

from meshlink import MeshlinkError
from skill_agent import AgentTransportError, SkillError
from skill_agent.client import AgentClient, find_skills, list_agents
from skill_agent.protocol import RunEvent, RunResult, SkillDescription
from wm_store import WmError
from wm_store.ontology import TYPED_KINDS, did_you_mean
from wm_store.protocol import Value

from ..errors import Exit, complain
from ..runtime import run_service
from ._connect import mesh_session
from ._run_view import RunLines, with_output
from ._store_reads import registered_agents
from ._table import print_table

__all__ = [
    "agents",
    "client",
    "parse_params",
    "print_event",
    "print_json",
    "reload",
    "run",
    "skills",
    "stop",
]

EXIT_FAILED, EXIT_REFUSED, EXIT_UNREACHABLE = Exit.FAILED, Exit.REFUSED, Exit.UNREACHABLE
EXIT_INTERRUPTED = Exit.INTERRUPTED


def client(args: argparse.Namespace, body: Callable[[argparse.Namespace], Awaitable[int]]) -> int:
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


def print_json(obj: object) -> None:
    sys.stdout.write(msgspec.json.encode(obj).decode() + "\n")
    sys.stdout.flush()


async def agents(args: argparse.Namespace) -> int:
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
        print_json(rows)
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


async def skills(args: argparse.Namespace) -> int:
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
        print_json({agent: reply.skills for agent, reply in replies.items()})
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


def print_event(event: RunEvent) -> None:
    RunLines()(event)


async def run(args: argparse.Namespace) -> int:
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

        json_out = print_json if args.json else None
        result = await with_output(run, agent=args.agent, skill=args.skill, json_out=json_out)
    return 0 if result.success else EXIT_FAILED


async def reload(args: argparse.Namespace) -> int:
    async with mesh_session(args) as mesh:
        print(await AgentClient(mesh, args.agent, timeout=args.timeout).reload())
    return 0


async def stop(args: argparse.Namespace) -> int:
    async with mesh_session(args) as mesh:
        result = await AgentClient(mesh, args.agent, timeout=args.timeout).stop(args.run_id)
    if args.json:
        print_json(result)
    else:
        print_event(result)
    return 0
