"""The world-model benchmark's latencies: raw Zenoh baselines, the meshlink round trip and
change propagation to a replica process."""

from __future__ import annotations

import struct
import time

import zenoh

from benchmarks.common import (
    Child,
    Stats,
    summarize,
)
from benchmarks.wm._bench import PAYLOAD, Bench, mass_at, now_ns, raw_keys
from meshlink import MeshConfig, open_mesh, to_zenoh_config
from meshlink.testing import call0
from wm_store import (
    WmClient,
)


def raw_baselines(bench: Bench, echo: Child) -> tuple[Stats, Stats]:
    """Raw Zenoh get round trip (perf_counter) and put -> subscriber one-way time
    (CLOCK_MONOTONIC) from this process to the echo process, both clients of the router."""
    plan = bench.plan
    rtt_key, oneway_key, _ = raw_keys(bench.mesh)
    payload = bytes(PAYLOAD)
    session = zenoh.open(to_zenoh_config(MeshConfig(connect=(bench.endpoint,), mesh=bench.mesh)))
    try:
        rtts: list[int] = []
        for i in range(plan.warmup_calls + plan.raw_calls):
            start = time.perf_counter_ns()
            replies = [r for r in session.get(rtt_key, payload=payload) if r.ok is not None]
            elapsed = time.perf_counter_ns() - start
            if len(replies) != 1:
                raise RuntimeError(f"raw get: {len(replies)} replies instead of 1")
            if i >= plan.warmup_calls:
                rtts.append(elapsed)
        publisher = session.declare_publisher(
            oneway_key, congestion_control=zenoh.CongestionControl.BLOCK
        )
        pad = bytes(PAYLOAD - 8)
        total = plan.warmup_calls + plan.raw_calls
        for _ in range(total):
            publisher.put(struct.pack("<q", time.monotonic_ns()) + pad)
            time.sleep(0.0005)  # paced: one message in flight, latency rather than throughput
        call0(publisher.undeclare)
    finally:
        call0(session.close)
    echo.send({"expect": total, "skip": plan.warmup_calls})
    got = echo.expect("oneway")
    if got["received"] != total:
        raise RuntimeError(f"raw put: {got['received']} of {total} samples arrived")
    return summarize(rtts, 1e-3), summarize(got["oneway"], 1e-3)


async def bridge_rtt(bench: Bench) -> Stats:
    """``Mesh.request`` round trip to a meshlink queryable: the anyio bridge on both ends."""
    *_, key = raw_keys(bench.mesh)
    payload = bytes(PAYLOAD)
    samples: list[int] = []
    config = MeshConfig(connect=(bench.endpoint,), mesh=bench.mesh)
    async with open_mesh(config) as mesh:
        for i in range(bench.plan.warmup_calls + bench.plan.raw_calls):
            start = time.perf_counter_ns()
            await mesh.request(key, payload, timeout=5.0)
            if i >= bench.plan.warmup_calls:
                samples.append(time.perf_counter_ns() - start)
    return summarize(samples, 1e-3)


async def propagation(
    bench: Bench, wm: WmClient, store: Child, replica: Child
) -> tuple[Stats, Stats, int]:
    """Sequential single-op commits by this process; the store stamps each change as it
    publishes it, the replica process as its ``on_change`` runs. Returns (publish -> apply,
    commit call -> remote apply, payload bytes of one change)."""
    target = await wm.add_element("Gear", label=f"propagation@{wm.revision}")  # labels unique
    first = wm.revision
    started: dict[int, int] = {}
    for i in range(bench.plan.changes):
        start = now_ns()
        revision = await wm.update_element(target, {"mass": mass_at(0, i)})
        started[revision] = start
    last = wm.revision
    store.send({"after": first})
    published = {r: (t, size) for r, t, size in (await store.expect_async("stamps"))["stamps"]}
    replica.send({"after": first, "until": last})
    applied: dict[int, int] = dict((await replica.expect_async("stamps"))["stamps"])
    revisions = sorted(started)
    missing = [r for r in revisions if r not in applied or r not in published]
    if missing:
        raise RuntimeError(f"{len(missing)} changes not stamped, e.g. revision {missing[0]}")
    one_way = summarize((applied[r] - published[r][0] for r in revisions), 1e-3)
    end_to_end = summarize((applied[r] - started[r] for r in revisions), 1e-3)
    return one_way, end_to_end, published[revisions[0]][1]
