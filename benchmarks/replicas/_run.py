"""The replica benchmark's runs, results and command line."""

from __future__ import annotations

import argparse
import cProfile
import functools
import io
import json
import pstats
import statistics
import sys
import time
from pathlib import Path

import anyio
import msgspec

from benchmarks.common import Row, format_table, machine_info, percentile
from benchmarks.replicas._cost import ReplayCost, replay_cost
from benchmarks.replicas._fleet import drive, fleet

__all__ = ["Case", "main", "run_case"]

TARGET = 2.0
"""Median step overhead at 50 robots at most this many times the one at 10 (same run)."""


class Case(msgspec.Struct, kw_only=True):
    robots: int
    replicas: str
    anonymous: bool = False
    steps: int = 0
    changes: int = 0
    median_ms: float = 0.0
    p90_ms: float = 0.0
    cpu_per_change_us: float = 0.0
    """CPU of the whole process (store, agents, replicas) per committed change."""
    replica_count: int = 0

    @property
    def name(self) -> str:
        return f"{self.robots} robots, {self.replicas}" + (", anonymous" if self.anonymous else "")


async def run_case(
    robots: int,
    replicas: str,
    *,
    steps: int,
    time_scale: float,
    anonymous: bool = False,
    cost: bool = False,
    profile: bool = False,
) -> tuple[Case, ReplayCost | None, str]:
    """One fleet run; with ``cost``, the replay of its changes; with ``profile``, the top of
    a profile of the drive."""
    async with fleet(robots, replicas=replicas, time_scale=time_scale, anonymous=anonymous) as f:
        payloads: list[bytes] = []
        f.store.add_listener(lambda _change, payload: payloads.append(payload))
        start = f.store.revision
        profiler = cProfile.Profile() if profile else None
        cpu = time.process_time()
        if profiler is not None:
            profiler.enable()
        overheads = sorted(await drive(f, steps))
        if profiler is not None:
            profiler.disable()
        cpu = time.process_time() - cpu
        changes = f.store.revision - start
        case = Case(
            robots=robots,
            replicas=replicas,
            anonymous=anonymous,
            steps=len(overheads),
            changes=changes,
            median_ms=statistics.median(overheads) * 1e3,
            p90_ms=percentile(overheads, 90) * 1e3,
            cpu_per_change_us=cpu / max(changes, 1) * 1e6,
            replica_count=f.replicas,
        )
        replayed = None
        if cost:
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


def rows(cases: list[Case], cost: ReplayCost | None) -> list[Row]:
    by = {(c.robots, c.replicas, c.anonymous): c for c in cases}
    out = []
    for replicas, anonymous in (("own", False), ("shared", False), ("own", True), ("shared", True)):
        small, large = by.get((10, replicas, anonymous)), by.get((50, replicas, anonymous))
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
        out.append(
            Row(figure=f"process CPU per change, {c.name}", value=c.cpu_per_change_us, unit="us")
        )
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


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(
        description=sys.modules["benchmarks.replicas"].__doc__,
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    parser.add_argument("--quick", action="store_true", help="3 steps per robot, one repetition")
    parser.add_argument("--steps", type=int, default=0, help="steps per robot (default 8)")
    parser.add_argument("--reps", type=int, default=0, help="repetitions (default 2)")
    parser.add_argument(
        "--time-scale", type=float, default=0.05, help="wall seconds per skill second"
    )
    parser.add_argument("--profile", action="store_true", help="profile the 50-robot shared run")
    parser.add_argument("--json", type=Path, help="also write the cases as JSON")
    args = parser.parse_args(argv)
    steps = args.steps or (3 if args.quick else 8)
    reps = args.reps or (1 if args.quick else 2)
    info = machine_info()
    print(" ".join(f"{k}={v}" for k, v in info.items()), file=sys.stderr)
    plan = [(10, "own", False), (50, "own", False), (10, "shared", False), (50, "shared", False)]
    plan += [(10, "own", True), (50, "own", True), (10, "shared", True), (50, "shared", True)]
    runs: dict[tuple[int, str, bool], list[Case]] = {}
    cost: ReplayCost | None = None
    top = ""
    for rep in range(reps):  # interleaved: 10 and 50 robots of one mode back to back
        for robots, replicas, anonymous in plan:
            label = f"{robots} robots, {replicas}{', anonymous' if anonymous else ''}"
            print(f"rep {rep + 1}: {label} ...", file=sys.stderr, flush=True)
            key = (robots, replicas, anonymous)
            case, replayed, profiled = anyio.run(
                functools.partial(
                    run_case,
                    robots,
                    replicas,
                    steps=steps,
                    time_scale=args.time_scale,
                    anonymous=anonymous,
                    cost=rep == 0 and key == (50, "own", False),
                    profile=args.profile and rep == 0 and key == (50, "shared", False),
                )
            )
            runs.setdefault(key, []).append(case)
            cost = replayed or cost
            top = profiled or top
    cases = [_median(v) for v in runs.values()]
    print(format_table(rows(cases, cost)))
    if cost is not None:
        print(f"\none replica with a listener, {cost.changes} changes of the 50-robot run:")
        print(cost.profile)
    if top:
        print("\nthe 50-robot shared run, top of the profile:")
        print(top)
    if args.json:
        out = {"machine": info, "cases": cases, "replay": cost}
        args.json.write_text(json.dumps(msgspec.to_builtins(out), indent=1))
    return 0


def _median(cases: list[Case]) -> Case:
    """The case with each figure the median over the repetitions."""
    first = cases[0]
    return msgspec.structs.replace(
        first,
        steps=sum(c.steps for c in cases),
        changes=sum(c.changes for c in cases),
        median_ms=statistics.median(c.median_ms for c in cases),
        p90_ms=statistics.median(c.p90_ms for c in cases),
        cpu_per_change_us=statistics.median(c.cpu_per_change_us for c in cases),
    )
