"""Skill-layer benchmarks: the round trip of a no-op skill run, and runs/s with concurrent callers.

    python -m benchmarks.skills            # full run (about a minute on 2 cores)
    python -m benchmarks.skills --quick    # smoke run, < 30 s
    python -m benchmarks.skills --json results.json

Figures (each beside a baseline measured in the same run; method and results:
``docs/benchmarks.md``, section "Skills"):

1. one no-op skill run, start -> final result, from this process to the agent process:
   ``AgentClient.run("noop")`` with the client's shared progress subscription (``async with
   AgentClient(...)``), p50 / p99 over >= 2,000 runs; and the same without the shared
   subscription (each run subscribes and watches liveliness first);
2. baselines to the same agent process: a raw Zenoh ``get`` round trip (synchronous
   zenoh-python, no event loop) and a ``Mesh.request`` round trip (the anyio bridge on both
   ends: what any skill request pays);
3. runs/s with 8 concurrent callers (one shared client), against 1 caller;
4. stop -> ``preempted``: a client stops a run of ``idle`` (waits in ``execute`` until
   stopped) in the agent process; time from the ``StopRun`` sent until the ``preempted``
   result arrives, on the run's progress stream and as the ``StopRun`` reply
   (``AgentClient.stop``), beside the raw get round trip of 2.

Processes: a Zenoh router, an in-memory world-model store and the agent (``noop`` from
``configs/agents/noop.toml`` plus :class:`Idle` from this module, and two echo queryables for
the baselines) are children of this script (``--role``), on 127.0.0.1 only (free port,
multicast scouting off), stopped by PID.
"""

from __future__ import annotations

import argparse
import contextlib
import signal
import sys
import time
import uuid
from collections.abc import Callable, Sequence
from pathlib import Path
from typing import Any

import anyio
import msgspec
import zenoh

from benchmarks.common import (
    ROOT,
    Child,
    Row,
    Stats,
    calibrate,
    child_router,
    emit,
    format_table,
    load_average,
    machine_info,
    start_router_child,
    stdin_lines,
    summarize,
)
from meshlink import Answer, IncomingQuery, MeshConfig, open_mesh, to_zenoh_config
from meshlink.bridge import call0, undeclare
from skill_agent.client import AgentClient, new_run_id
from skill_agent.config import AgentConfig, load_config
from skill_agent.protocol import Progress, RunEvent, RunResult, SkillDescription
from skill_agent.server import run_agent
from skill_agent.skill import Skill, SkillContext
from skimesh.runtime import run_service
from wm_store import Ontology, StoreConfig, WmStore, serve_store

BREAKDOWN = {
    "request": "start sent -> agent's first event (request delivery, dispatch, start)",
    "agent": "first event -> result, in the agent (lifecycle, 7 events published)",
    "result": "result stamped -> result in the client's loop (publication delivery)",
}
PAYLOAD = 200  # bytes of the baseline replies (a StartRun / RunStarted pair is ~100-200 bytes)
AGENT = "noop"
CALLERS = 8
IDLE_SKILL = "benchmarks.skills:Idle"


class Idle(Skill):
    """Waits in ``execute`` until stopped; nothing to make safe. What the stop figure stops."""

    description = SkillDescription(name="idle", doc="Waits until stopped.", duration=0.0)

    async def execute(self, ctx: SkillContext) -> None:
        await anyio.sleep_forever()


class Plan(msgspec.Struct, frozen=True):
    runs: int
    per_run_subscription_runs: int
    warmup: int
    raw_calls: int
    throughput_seconds: float
    stops: int


FULL = Plan(
    runs=2000,
    per_run_subscription_runs=500,
    warmup=200,
    raw_calls=2000,
    throughput_seconds=5.0,
    stops=1000,
)
QUICK = Plan(
    runs=300,
    per_run_subscription_runs=100,
    warmup=50,
    raw_calls=300,
    throughput_seconds=1.5,
    stops=150,
)


def agent_config() -> AgentConfig:
    """``configs/agents/noop.toml`` with :class:`Idle` added to its skills."""
    config = load_config(ROOT / "configs" / "agents" / f"{AGENT}.toml")
    skills = msgspec.structs.replace(config.skills, paths=[*config.skills.paths, IDLE_SKILL])
    return msgspec.structs.replace(config, skills=skills)


def echo_keys(mesh: str) -> tuple[str, str]:
    base = f"skimesh/{mesh}/bench"
    return f"{base}/skills-raw", f"{base}/skills-bridge"


# =========================================================================== child roles


def child_store(args: argparse.Namespace) -> int:
    async def main() -> int:
        store = await WmStore.open(Ontology.default(), StoreConfig(durability="none"))
        config = MeshConfig(connect=(args.connect,), mesh=args.mesh)
        async with open_mesh(config) as mesh, anyio.create_task_group() as tg:
            await tg.start(serve_store, mesh, store)
            emit({"ready": True})
            async for _ in stdin_lines():
                pass
            tg.cancel_scope.cancel()
        return 0

    return run_service(main)


def child_agent(args: argparse.Namespace) -> int:
    """The no-op agent, plus a raw Zenoh echo queryable and a meshlink echo on its session."""
    raw_key, bridge_key = echo_keys(args.mesh)
    reply = bytes(PAYLOAD)

    def on_query(query: zenoh.Query) -> None:  # zenoh's thread for this queryable
        with query:
            query.reply(query.key_expr, reply)

    async def bridge_echo(_query: IncomingQuery) -> list[Answer]:
        return [Answer(key=bridge_key, payload=reply)]

    async def main() -> int:
        config = agent_config()
        mesh_config = MeshConfig(connect=(args.connect,), mesh=args.mesh)
        async with open_mesh(mesh_config) as mesh, anyio.create_task_group() as tg:
            queryable = mesh.session.declare_queryable(raw_key, on_query)
            try:
                await tg.start(mesh.serve, bridge_key, bridge_echo)
                await tg.start(run_agent, mesh, config)
                emit({"ready": True})
                async for _ in stdin_lines():
                    pass
            finally:
                undeclare(queryable)
                tg.cancel_scope.cancel()
        return 0

    return run_service(main)


# =========================================================================== measurements


def raw_rtt(endpoint: str, mesh: str, plan: Plan) -> Stats:
    """Synchronous zenoh-python gets to the agent process's raw echo (no event loop)."""
    raw_key, _ = echo_keys(mesh)
    session = zenoh.open(to_zenoh_config(MeshConfig(connect=(endpoint,), mesh=mesh)))
    samples: list[int] = []
    try:
        for i in range(plan.warmup + plan.raw_calls):
            start = time.perf_counter_ns()
            replies = [r for r in session.get(raw_key, payload=bytes(PAYLOAD)) if r.ok is not None]
            elapsed = time.perf_counter_ns() - start
            if len(replies) != 1:
                raise RuntimeError(f"raw get: {len(replies)} replies instead of 1")
            if i >= plan.warmup:
                samples.append(elapsed)
    finally:
        call0(session.close)
    return summarize(samples, 1e-3)


async def measured_phases(endpoint: str, mesh_name: str, plan: Plan) -> dict[str, Any]:
    _, bridge_key = echo_keys(mesh_name)
    out: dict[str, Any] = {}
    async with open_mesh(MeshConfig(connect=(endpoint,), mesh=mesh_name)) as mesh:
        samples: list[int] = []
        for i in range(plan.warmup + plan.raw_calls):
            start = time.perf_counter_ns()
            await mesh.request(bridge_key, bytes(PAYLOAD), timeout=5.0)
            if i >= plan.warmup:
                samples.append(time.perf_counter_ns() - start)
        out["bridge_rtt_us"] = summarize(samples, 1e-3)

        async def timed_runs(client: AgentClient, count: int) -> tuple[Stats, dict[str, Stats]]:
            times: list[int] = []
            parts: dict[str, list[float]] = {"request": [], "agent": [], "result": []}
            for i in range(plan.warmup + count):
                seen: list[tuple[RunEvent, float]] = []

                def record(event: RunEvent, out: list[tuple[RunEvent, float]] = seen) -> None:
                    out.append((event, time.time()))

                sent = time.time()
                start = time.perf_counter_ns()
                result = await client.run("noop", on_event=record)
                elapsed = time.perf_counter_ns() - start
                if not result.success:
                    raise RuntimeError(f"noop run failed: {result.message}")
                if i >= plan.warmup:
                    times.append(elapsed)
                    first, last = seen[0][0], seen[-1]
                    first_stamp = first.stamp if isinstance(first, Progress) else sent
                    parts["request"].append(first_stamp - sent)
                    parts["agent"].append(result.finished_at - first_stamp)
                    parts["result"].append(last[1] - result.finished_at)
            return summarize(times, 1e-3), {k: summarize(v, 1e6) for k, v in parts.items()}

        async with AgentClient(mesh, AGENT) as shared:
            out["call_us"] = await timed_calls(shared, plan.warmup, plan.runs)
            out["run_us"], out["breakdown_us"] = await timed_runs(shared, plan.runs)
            out["runs_per_s_1"] = await throughput(shared, 1, plan.throughput_seconds)
            out[f"runs_per_s_{CALLERS}"] = await throughput(
                shared, CALLERS, plan.throughput_seconds
            )
            out["stop_published_us"], out["stop_replied_us"] = await timed_stops(
                shared, plan.warmup // 4, plan.stops
            )
        out["run_per_run_subscription_us"], _ = await timed_runs(
            AgentClient(mesh, AGENT), plan.per_run_subscription_runs
        )
    return out


async def timed_calls(client: AgentClient, warmup: int, count: int) -> Stats:
    """``AgentClient.call``: start -> result in one request (``StartRun(wait=True)``)."""
    times: list[int] = []
    for i in range(warmup + count):
        start = time.perf_counter_ns()
        result = await client.call("noop")
        elapsed = time.perf_counter_ns() - start
        if not result.success:
            raise RuntimeError(f"noop call failed: {result.message}")
        if i >= warmup:
            times.append(elapsed)
    return summarize(times, 1e-3)


async def timed_stops(client: AgentClient, warmup: int, count: int) -> tuple[Stats, Stats]:
    """Stop a run of ``idle`` once it executes, ``warmup + count`` times: ``StopRun`` sent ->
    the ``preempted`` result on the run's progress stream, and -> the ``StopRun`` reply
    carrying it (both in flight at once, as for any caller that watches the run it stops)."""
    published: list[int] = []
    replied: list[int] = []
    for i in range(warmup + count):
        on_stream, in_reply = await one_stop(client)
        if i >= warmup:
            published.append(on_stream)
            replied.append(in_reply)
    return summarize(published, 1e-3), summarize(replied, 1e-3)


async def one_stop(client: AgentClient) -> tuple[int, int]:
    """Start ``idle``, wait until it executes, stop it: ns until the result was published
    (seen on the progress stream) and until ``AgentClient.stop`` returned it."""
    run_id = new_run_id()
    times: dict[str, int] = {}

    def check(result: RunResult) -> None:
        if result.reason != "preempted":
            raise RuntimeError(f"idle run ended {result.reason}: {result.message}")

    async with client.watch(run_id) as events:
        await client.start("idle", run_id=run_id)
        async for event in events:
            if isinstance(event, Progress) and event.state == "executing":
                break
        start = time.perf_counter_ns()

        async def stop() -> None:
            check(await client.stop(run_id))
            times["reply"] = time.perf_counter_ns() - start

        async with anyio.create_task_group() as tg:
            tg.start_soon(stop)
            async for event in events:
                if isinstance(event, RunResult):
                    times["stream"] = time.perf_counter_ns() - start
                    check(event)
                    break
    if "stream" not in times:
        raise RuntimeError(f"run {run_id}: the progress stream ended without the result")
    return times["stream"], times["reply"]


async def throughput(client: AgentClient, callers: int, seconds: float) -> float:
    done = 0
    stop_at = time.perf_counter() + seconds

    async def caller() -> None:
        nonlocal done
        while time.perf_counter() < stop_at:
            result = await client.run("noop")
            if not result.success:
                raise RuntimeError(f"noop run failed: {result.message}")
            done += 1

    start = time.perf_counter()
    async with anyio.create_task_group() as tg:
        for _ in range(callers):
            tg.start_soon(caller)
    return done / (time.perf_counter() - start)


def make_rows(d: dict[str, Any]) -> list[Row]:
    raw: Stats = d["raw_rtt_us"]
    bridge: Stats = d["bridge_rtt_us"]
    run: Stats = d["run_us"]
    per_run: Stats = d["run_per_run_subscription_us"]
    one, many = d["runs_per_s_1"], d[f"runs_per_s_{CALLERS}"]
    return [
        Row(figure="raw Zenoh get round trip p50", value=raw.p50, unit="us"),
        Row(
            figure="meshlink request round trip p50",
            value=bridge.p50,
            unit="us",
            baseline="raw get p50",
            baseline_value=raw.p50,
        ),
        Row(
            figure="no-op skill run p50 (start -> result)",
            value=run.p50,
            unit="us",
            baseline="raw get p50",
            baseline_value=raw.p50,
            target="<= 3x raw get",
            met=run.p50 <= 3 * raw.p50,
        ),
        Row(
            figure="no-op skill call p50 (StartRun wait=True)",
            value=d["call_us"].p50,
            unit="us",
            baseline="raw get p50",
            baseline_value=raw.p50,
            target="<= 3x raw get",
            met=d["call_us"].p50 <= 3 * raw.p50,
        ),
        Row(
            figure="no-op skill call p99",
            value=d["call_us"].p99,
            unit="us",
            baseline="raw get p99",
            baseline_value=raw.p99,
        ),
        Row(
            figure="no-op skill run p99",
            value=run.p99,
            unit="us",
            baseline="raw get p99",
            baseline_value=raw.p99,
        ),
        Row(
            figure="no-op run p50, per-run subscription",
            value=per_run.p50,
            unit="us",
            baseline="shared p50",
            baseline_value=run.p50,
        ),
        Row(
            figure="no-op run p99, per-run subscription",
            value=per_run.p99,
            unit="us",
            baseline="shared p99",
            baseline_value=run.p99,
        ),
        Row(
            figure=f"runs/s, {CALLERS} concurrent callers",
            value=many,
            unit="runs/s",
            baseline="1 caller",
            baseline_value=one,
        ),
        Row(
            figure="stop -> preempted result published, p50",
            value=d["stop_published_us"].p50,
            unit="us",
            baseline="raw get p50",
            baseline_value=raw.p50,
        ),
        Row(
            figure="stop -> preempted result published, p99",
            value=d["stop_published_us"].p99,
            unit="us",
            baseline="raw get p99",
            baseline_value=raw.p99,
        ),
        Row(
            figure="stop -> StopRun reply with the result, p50",
            value=d["stop_replied_us"].p50,
            unit="us",
            baseline="raw get p50",
            baseline_value=raw.p50,
        ),
        Row(
            figure="stop -> StopRun reply with the result, p99",
            value=d["stop_replied_us"].p99,
            unit="us",
            baseline="raw get p99",
            baseline_value=raw.p99,
        ),
    ]


# =========================================================================== orchestration


def _terminate(signum: int, _frame: object) -> None:
    raise SystemExit(128 + signum)  # unwinds the ExitStack: children stopped by PID


def start_router(stack: contextlib.ExitStack) -> str:
    return start_router_child("benchmarks.skills", stack)


def run(plan: Plan, json_path: Path | None) -> int:
    signal.signal(signal.SIGTERM, _terminate)
    info = machine_info(("eclipse-zenoh", "msgspec", "anyio"))
    conditions = {"load_start": load_average(), "calibration_ms_start": calibrate()}
    mesh = f"bench-{uuid.uuid4().hex[:10]}"
    started = time.perf_counter()
    with contextlib.ExitStack() as stack:
        endpoint = start_router(stack)
        for role in ("store", "agent"):
            child = Child(
                ["-m", "benchmarks.skills", "--role", role, "--connect", endpoint, "--mesh", mesh],
                name=role,
            )
            stack.callback(child.stop)
            child.expect("ready", timeout=60)
        print(f"router, store, agent up (mesh {mesh}); measuring...", file=sys.stderr, flush=True)
        details: dict[str, Any] = {"raw_rtt_us": raw_rtt(endpoint, mesh, plan)}
        details |= anyio.run(measured_phases, endpoint, mesh, plan)
    conditions |= {"load_end": load_average(), "calibration_ms_end": calibrate()}
    rows = make_rows(details)
    print("machine: " + ", ".join(f"{k} {v}" for k, v in info.items()))
    print(
        f"run: {'quick' if plan is QUICK else 'full'}, {time.perf_counter() - started:.0f} s; "
        f"load average {conditions['load_start']} at start, {conditions['load_end']} at end\n"
    )
    print(format_table(rows))
    for name in (
        "raw_rtt_us",
        "bridge_rtt_us",
        "run_us",
        "run_per_run_subscription_us",
        "stop_published_us",
        "stop_replied_us",
    ):
        s: Stats = details[name]
        print(
            f"{name}: n={s.count} p50={s.p50:.0f} p90={s.p90:.0f} p99={s.p99:.0f} max={s.max:.0f}"
        )
    print("where a no-op run's time goes (shared client; wall clocks of both processes, us):")
    breakdown: dict[str, Stats] = details["breakdown_us"]
    for part, what in BREAKDOWN.items():
        b = breakdown[part]
        print(f"  {what}: p50={b.p50:.0f} p99={b.p99:.0f}")
    if json_path is not None:
        doc = {
            "machine": info,
            "conditions": conditions,
            "plan": plan,
            "rows": rows,
            "details": details,
        }
        json_path.write_bytes(msgspec.json.format(msgspec.json.encode(doc)))
    return 0


def main(argv: Sequence[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=(__doc__ or "").split("\n\n")[0])
    parser.add_argument("--quick", action="store_true", help="short smoke run (< 30 s)")
    parser.add_argument("--json", type=Path, metavar="FILE", help="also write results as JSON")
    hidden = argparse.SUPPRESS
    parser.add_argument("--role", choices=("router", "store", "agent"), help=hidden)
    parser.add_argument("--listen", help=hidden)
    parser.add_argument("--connect", help=hidden)
    parser.add_argument("--mesh", help=hidden)
    args = parser.parse_args(argv)
    roles: dict[str, Callable[[argparse.Namespace], int]] = {
        "router": child_router,
        "store": child_store,
        "agent": child_agent,
    }
    if args.role:
        return roles[args.role](args)
    return run(QUICK if args.quick else FULL, args.json)


if __name__ == "__main__":
    sys.exit(main())
