"""The skill benchmark's measurements: raw round trips, timed no-op runs, stops, runs/s."""

from __future__ import annotations

import time
from typing import Any

import anyio
import zenoh

from benchmarks.common import (
    Stats,
    summarize,
)
from benchmarks.skills._setup import AGENT, CALLERS, PAYLOAD, Plan, echo_keys
from meshlink import MeshConfig, open_mesh, to_zenoh_config
from meshlink.testing import call0
from skill_agent.client import AgentClient, new_run_id
from skill_agent.protocol import Progress, RunEvent, RunResult


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
