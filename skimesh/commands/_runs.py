"""The skill agents' runs from the command line: ``skimesh runs [AGENT] [RUN]`` (list the
runs, or one run's state and history, ``--follow`` to its end), ``skimesh pause AGENT RUN`` and
``skimesh resume AGENT RUN``, beside ``skimesh run`` and ``skimesh stop`` (``agent.py``).

Each agent keeps its running runs and its last 256 ended ones, with at most 500 events per run
(``skill_agent.server.RunHistory``); ``runs AGENT RUN`` prints what it kept, then, with
``--follow``, the live events until the result, each once (``AgentClient.follow``).
"""

from __future__ import annotations

import argparse
import sys
import time
from collections.abc import Awaitable, Callable

import msgspec

from meshlink import Mesh
from skill_agent import SkillError
from skill_agent.client import AgentClient, list_agents
from skill_agent.protocol import Progress, RunEvent, RunInfo, RunResult

from ._connect import mesh_session
from ._table import print_table

__all__ = ["add_parsers"]

Sub = argparse._SubParsersAction  # argparse keeps the sub-parsers action class private
Body = Callable[[argparse.Namespace], Awaitable[int]]
EXIT_FAILED, EXIT_USAGE = 1, 2


def add_parsers(
    sub: Sub[argparse.ArgumentParser],
    *,
    client_arguments: Callable[[argparse.ArgumentParser], None],
    client: Callable[[argparse.Namespace, Body], int],
    print_event: Callable[[RunEvent], None],
    print_json: Callable[[object], None],
) -> None:
    """Add ``runs``, ``pause`` and ``resume``; ``client`` runs a command body (exit codes),
    ``print_event`` / ``print_json`` print a run event as ``skimesh run`` does."""
    show = _Show(print_event, print_json)
    runs = sub.add_parser(
        "runs",
        help="list the runs of the agents, or show one run and its history (--follow)",
        description="Without RUN: the runs every agent (or AGENT) keeps, running and recently "
        "ended: id, skill, parameters, state, start, elapsed time, outcome. With AGENT RUN: "
        "that run's state and every event the agent kept of it; --follow then prints its "
        "live events until its result. Exit codes: 0 (with --follow: the run succeeded), "
        "1 it failed, 2 no such run, 3 the agent could not be reached.",
    )
    runs.add_argument("agent", nargs="?", help="only this agent's runs (default: every agent)")
    runs.add_argument("run_id", nargs="?", metavar="RUN", help="one run: its state and history")
    runs.add_argument("--active", action="store_true", help="running runs only")
    runs.add_argument("--follow", action="store_true", help="with RUN: follow it to its end")
    client_arguments(runs)
    runs.set_defaults(func=lambda a: client(a, show.runs))

    for verb, what in (("pause", "hold a run at its next checkpoint"), ("resume", "resume it")):
        p = sub.add_parser(
            verb,
            help=f"{what} (`skimesh runs` lists the runs)",
            description=f"{what[0].upper()}{what[1:]} on the agent running it. Exit codes: 0 "
            "done, 2 refused (no such run, it has ended, not paused / paused already), 3 the "
            "agent could not be reached.",
        )
        p.add_argument("agent", help="the agent running it")
        p.add_argument("run_id", metavar="RUN", help="the run's id (see `skimesh runs`)")
        client_arguments(p)
        p.set_defaults(func=lambda a, v=verb: client(a, lambda args: show.hold(args, v)))


def _elapsed(info: RunInfo, now: float) -> float:
    end = info.result.finished_at if info.result is not None else now
    return max(0.0, end - info.started_at) if info.started_at else 0.0


def _outcome(info: RunInfo) -> str:
    r = info.result
    if r is None:
        return "-"
    return "ok" if r.success else f"{r.reason}: {r.message}" if r.message else r.reason


def _params(info: RunInfo) -> str:
    return " ".join(f"{k}={v}" for k, v in info.params.items())


def run_row(agent: str, info: RunInfo, now: float) -> list[str]:
    """AGENT RUN SKILL PARAMS STATE STARTED ELAPSED OUTCOME."""
    started = time.strftime("%H:%M:%S", time.localtime(info.started_at)) if info.started_at else "-"
    return [
        agent,
        info.run_id,
        info.skill,
        _params(info),
        info.state,
        started,
        f"{_elapsed(info, now):.1f} s",
        _outcome(info),
    ]


HEAD = ("AGENT", "RUN", "SKILL", "PARAMS", "STATE", "STARTED", "ELAPSED", "OUTCOME")


class _Show:
    def __init__(
        self, print_event: Callable[[RunEvent], None], print_json: Callable[[object], None]
    ) -> None:
        self.print_event, self.print_json = print_event, print_json

    async def runs(self, args: argparse.Namespace) -> int:
        if args.run_id:
            return await self.one(args)
        if args.follow:
            print("skimesh runs: --follow needs AGENT RUN", file=sys.stderr)
            return EXIT_USAGE
        async with mesh_session(args) as mesh:
            found = await _runs(mesh, args.agent, args.active, args.timeout)
        if args.json:
            self.print_json([{"agent": a, **msgspec.to_builtins(i)} for a, i in found])
            return 0
        if not found:
            print("no runs")
            return 0
        now = time.time()
        print_table(HEAD, [run_row(a, i, now) for a, i in found])
        return 0

    async def one(self, args: argparse.Namespace) -> int:
        async with (
            mesh_session(args) as mesh,
            AgentClient(mesh, args.agent, timeout=args.timeout) as client,
        ):
            if not args.follow:
                reply = await client.run_events(args.run_id)
                self._head(args, reply.run, reply.dropped)
                for event in reply.events:
                    self._event(args, reply.run, event)
                return 0
            async with client.follow(args.run_id) as (info, events):
                self._head(args, info, 0)
                result: RunResult | None = None
                async for event in events:
                    self._event(args, info, event)
                    result = event if isinstance(event, RunResult) else None
        return 0 if result is not None and result.success else EXIT_FAILED

    def _head(self, args: argparse.Namespace, info: RunInfo, dropped: int) -> None:
        if args.json:
            self.print_json({"agent": args.agent, **msgspec.to_builtins(info)})
            return
        row = run_row(args.agent, info, time.time())
        print(f"{info.skill} {info.run_id} on {args.agent}: {info.state}, started {row[5]}, "
              f"{row[6]}; outcome {row[7]}")  # fmt: skip
        if info.params:
            print(f"  params: {_params(info)}")
        if dropped:
            print(f"  ({dropped} earlier progress events not kept by the agent)")

    def _event(self, args: argparse.Namespace, info: RunInfo, event: RunEvent) -> None:
        if args.json:
            self.print_json(event)
        elif isinstance(event, Progress) and info.started_at:
            print(f"{event.stamp - info.started_at:7.2f}s", end="")
            self.print_event(event)
        else:
            self.print_event(event)

    async def hold(self, args: argparse.Namespace, verb: str) -> int:
        async with mesh_session(args) as mesh:
            client = AgentClient(mesh, args.agent, timeout=args.timeout)
            await (client.pause if verb == "pause" else client.resume)(args.run_id)
            info = await client.status(args.run_id)
        if args.json:
            self.print_json({"agent": args.agent, **msgspec.to_builtins(info)})
        else:
            now = "" if info.state == f"{verb}d" else f" (now {info.state})"
            print(f"{info.skill} {args.run_id} on {args.agent}: {verb}d{now}")
        return 0


async def _runs(
    mesh: Mesh, agent: str | None, active: bool, timeout: float
) -> list[tuple[str, RunInfo]]:
    names = [agent] if agent else sorted(await list_agents(mesh, timeout=timeout))
    found: list[tuple[str, RunInfo]] = []
    for name in names:
        try:
            runs = await AgentClient(mesh, name, timeout=timeout).runs(active_only=active)
        except SkillError as e:
            if agent:
                raise
            print(f"warning: agent {name}: {e}", file=sys.stderr)  # the others still answer
            continue
        found += [(name, info) for info in runs]
    return sorted(found, key=lambda f: f[1].started_at)
