"""The replica benchmark's runs, results and command line."""

from __future__ import annotations

import argparse
import contextlib
import cProfile
import functools
import io
import json
import pstats
import signal
import statistics
import sys
import time
import uuid
from collections.abc import AsyncIterator
from pathlib import Path

import anyio
import msgspec

from benchmarks.common import (
    Child,
    Row,
    format_table,
    load_average,
    machine_info,
    percentile,
    start_router_child,
)
from benchmarks.replicas._cost import ReplayCost, replay_cost
from benchmarks.replicas._fleet import Fleet, drive, fleet
from meshlink import MeshConfig, open_mesh
from wm_store import ZenohTransport

__all__ = ["Case", "main", "run_case"]

TARGET = 2.0
"""Median step overhead at 50 robots at most this many times the one at 10 (same run)."""

_STORE_ROLE = "benchmarks.skills"
"""The benchmark whose ``--role store`` child serves an empty in-memory store on a mesh."""


class Case(msgspec.Struct, kw_only=True):
    robots: int
    replicas: str
    anonymous: bool = False
    zenoh: bool = False
    steps: int = 0
    changes: int = 0
    median_ms: float = 0.0
    p90_ms: float = 0.0
    cpu_per_change_us: float = 0.0
    """CPU of this process (agents, replicas, and the store when in-process) per change."""
    replica_count: int = 0

    @property
    def name(self) -> str:
        where = "Zenoh" if self.zenoh else "in-process"
        extra = ", anonymous" if self.anonymous else ""
        return f"{self.robots} robots, {self.replicas}{extra} ({where})"


@contextlib.asynccontextmanager
async def _fleet(
    robots: int, replicas: str, time_scale: float, anonymous: bool, endpoint: str
) -> AsyncIterator[Fleet]:
    if not endpoint:
        async with fleet(
            robots, replicas=replicas, time_scale=time_scale, anonymous=anonymous
        ) as f:
            yield f
        return
    mesh_name = f"bench-{uuid.uuid4().hex[:10]}"
    with contextlib.ExitStack() as stack:
        child = Child(
            ["-m", _STORE_ROLE, "--role", "store", "--connect", endpoint, "--mesh", mesh_name],
            name="store",
        )
        stack.callback(child.stop)
        await anyio.to_thread.run_sync(functools.partial(child.expect, "ready", timeout=60))
        async with (
            open_mesh(MeshConfig(connect=(endpoint,), mesh=mesh_name)) as mesh,
            fleet(
                robots,
                replicas=replicas,
                time_scale=time_scale,
                anonymous=anonymous,
                transport=ZenohTransport(mesh),
            ) as f,
        ):
            yield f


async def run_case(
    robots: int,
    replicas: str,
    *,
    steps: int,
    time_scale: float,
    anonymous: bool = False,
    endpoint: str = "",
    cost: bool = False,
    profile: bool = False,
) -> tuple[Case, ReplayCost | None, str]:
    """One fleet run (over Zenoh through the router at ``endpoint``, else in-process); with
    ``cost``, the replay of its changes (in-process only); with ``profile``, the top of a
    profile of the drive."""
    async with _fleet(robots, replicas, time_scale, anonymous, endpoint) as f:
        payloads: list[bytes] = []
        if f.store is not None:
            f.store.add_listener(lambda _change, payload: payloads.append(payload))
        start = f.wm.revision
        profiler = cProfile.Profile() if profile else None
        cpu = time.process_time()
        if profiler is not None:
            profiler.enable()
        overheads = sorted(await drive(f, steps))
        if profiler is not None:
            profiler.disable()
        cpu = time.process_time() - cpu
        changes = f.wm.revision - start
        case = Case(
            robots=robots,
            replicas=replicas,
            anonymous=anonymous,
            zenoh=bool(endpoint),
            steps=len(overheads),
            changes=changes,
            median_ms=statistics.median(overheads) * 1e3,
            p90_ms=percentile(overheads, 90) * 1e3,
            cpu_per_change_us=cpu / max(changes, 1) * 1e6,
            replica_count=f.replicas,
        )
        replayed = None
        if cost and payloads:
            agent = f.agents[0]
            replayed = await replay_cost(
                f.wm.ontology,
                f.wm.transport.request,
                start,
                payloads,
                {"robot": agent.robot, "start": f.depot},
            )
        top = ""
        if profiler is not None:
            out = io.StringIO()
            pstats.Stats(profiler, stream=out).sort_stats("tottime").print_stats(10)
            top = out.getvalue()
        return case, replayed, top


_MODES = (("own", False), ("shared", False), ("own", True), ("shared", True))


def rows(cases: list[Case], cost: ReplayCost | None) -> list[Row]:
    by = {(c.robots, c.replicas, c.anonymous, c.zenoh): c for c in cases}
    out = []
    for zenoh in (False, True):
        for replicas, anonymous in _MODES:
            small = by.get((10, replicas, anonymous, zenoh))
            large = by.get((50, replicas, anonymous, zenoh))
            if small is None or large is None:
                continue
            ratio = large.median_ms / small.median_ms if small.median_ms else float("nan")
            out.append(
                Row(
                    figure=f"median step overhead, {large.name}",
                    value=large.median_ms,
                    unit="ms",
                    baseline=small.name,
                    baseline_value=small.median_ms,
                    target=f"<= {TARGET:g}x",
                    met=ratio <= TARGET,
                )
            )
    for c in cases:
        out.append(Row(figure=f"CPU per change, {c.name}", value=c.cpu_per_change_us, unit="us"))
    if cost is not None:
        out += [
            Row(figure="one replica: decode a change", value=cost.decode_us, unit="us"),
            Row(figure="one replica: decode + apply + index", value=cost.replica_us, unit="us"),
            Row(
                figure=f"one replica: the same + {cost.listeners} hold-condition listener",
                value=cost.listener_us,
                unit="us",
            ),
        ]
    return out


def _terminate(signum: int, _frame: object) -> None:
    raise SystemExit(128 + signum)  # unwinds the ExitStack: children stopped by PID


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(
        description=sys.modules["benchmarks.replicas"].__doc__,
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    parser.add_argument("--quick", action="store_true", help="3 steps per robot, one repetition")
    parser.add_argument("--steps", type=int, default=0, help="steps per robot (default 6)")
    parser.add_argument("--reps", type=int, default=0, help="repetitions (default 2)")
    parser.add_argument(
        "--time-scale", type=float, default=0.2, help="wall seconds per skill second"
    )
    parser.add_argument(
        "--transport",
        choices=("memory", "zenoh", "both"),
        default="both",
        help="the store in-process, in a child over Zenoh, or both (default)",
    )
    parser.add_argument("--profile", action="store_true", help="profile the 50-robot shared run")
    parser.add_argument("--json", type=Path, help="also write the cases as JSON")
    args = parser.parse_args(argv)
    signal.signal(signal.SIGTERM, _terminate)
    steps = args.steps or (3 if args.quick else 6)
    reps = args.reps or (1 if args.quick else 2)
    info = machine_info(("eclipse-zenoh", "msgspec", "anyio"))
    print(" ".join(f"{k}={v}" for k, v in info.items()), file=sys.stderr)
    load = load_average()
    plan = []
    if args.transport in ("memory", "both"):
        plan += [(r, m, a, False) for m, a in _MODES for r in (10, 50)]
    if args.transport in ("zenoh", "both"):
        plan += [(r, m, False, True) for m in ("own", "shared") for r in (10, 50)]
    runs: dict[tuple[int, str, bool, bool], list[Case]] = {}
    cost: ReplayCost | None = None
    top = ""
    with contextlib.ExitStack() as stack:
        endpoint = ""
        if any(zenoh for *_, zenoh in plan):
            endpoint = start_router_child(_STORE_ROLE, stack)
        for rep in range(reps):  # 10 and 50 robots of one mode back to back
            for key in plan:
                robots, replicas, anonymous, zenoh = key
                case = Case(robots=robots, replicas=replicas, anonymous=anonymous, zenoh=zenoh)
                print(f"rep {rep + 1}: {case.name} ...", file=sys.stderr, flush=True)
                case, replayed, profiled = anyio.run(
                    functools.partial(
                        run_case,
                        robots,
                        replicas,
                        steps=steps,
                        time_scale=args.time_scale,
                        anonymous=anonymous,
                        endpoint=endpoint if zenoh else "",
                        cost=rep == 0 and key == (50, "own", False, False),
                        profile=args.profile and rep == 0 and key == (50, "shared", False, False),
                    )
                )
                runs.setdefault(key, []).append(case)
                cost = replayed or cost
                top = profiled or top
    cases = [_median(v) for v in runs.values()]
    print(
        f"time scale {args.time_scale:g}, {steps} steps per robot, {reps} repetitions; load {load}"
    )
    print(format_table(rows(cases, cost)))
    if cost is not None:
        print(f"\none replica with a listener, {cost.changes} changes of the 50-robot run:")
        print(cost.profile)
    if top:
        print("\nthe 50-robot shared run, top of the profile:")
        print(top)
    if args.json:
        out = {"machine": info, "load": load, "cases": cases, "replay": cost}
        args.json.write_text(json.dumps(msgspec.to_builtins(out), indent=1))
    return 0


def _median(cases: list[Case]) -> Case:
    """The case with each figure the median over the repetitions."""
    return msgspec.structs.replace(
        cases[0],
        steps=sum(c.steps for c in cases),
        changes=sum(c.changes for c in cases),
        median_ms=statistics.median(c.median_ms for c in cases),
        p90_ms=statistics.median(c.p90_ms for c in cases),
        cpu_per_change_us=statistics.median(c.cpu_per_change_us for c in cases),
    )
