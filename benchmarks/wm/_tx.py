"""The world-model benchmark's durable transactions/s, in-process and through Zenoh."""

from __future__ import annotations

import shutil
import time
import uuid
from collections.abc import Awaitable, Callable

import anyio
import msgspec

from benchmarks.common import (
    Stats,
    cpu_seconds,
    summarize,
)
from benchmarks.wm._bench import Bench, mass_at
from wm_store import WmClient
from wm_store.durability import DurabilityMode, DurabilityStats
from wm_store.protocol import AddElement, Op, Transact, UpdateElement
from wm_store.server import StoreConfig, WmStore


class TxResult(msgspec.Struct):
    path: str
    mode: str
    writers: int
    tx: int
    seconds: float
    tps: float
    commit: Stats  # latency of one commit, ms
    logged: int = 0  # records the log acknowledged in the window
    fsyncs: int = 0  # commit fsyncs in the window
    cpu_us_per_tx: dict[str, float] = {}  # CPU time per tx in the window, by process


class CpuMeter:
    """CPU seconds of this process ("bench") and of named children, between two marks."""

    def __init__(self, pids: dict[str, int]) -> None:
        self.pids = {"bench": None, **pids}
        self.marks: list[dict[str, float]] = []

    def mark(self) -> None:
        self.marks.append({name: cpu_seconds(pid) for name, pid in self.pids.items()})

    def per_tx(self, count: int) -> dict[str, float]:
        first, last = self.marks[0], self.marks[-1]
        return {name: (last[name] - first[name]) * 1e6 / max(count, 1) for name in first}


async def drive_writers(
    commit: Callable[[int, int], Awaitable[object]],
    writers: int,
    warmup: float,
    seconds: float,
    on_window: Callable[[], object] = lambda: None,
) -> tuple[int, float, list[int]]:
    """Run ``writers`` tasks calling ``commit(writer, i)`` back to back; count the commits that
    complete inside the measured window (after ``warmup``); ``on_window()`` runs as the window
    opens and as it closes. Returns (count, window in s, latencies in ns of the commits both
    started and completed inside the window)."""
    measuring = False
    stop = False
    count = 0
    latencies: list[int] = []

    async def writer(w: int) -> None:
        nonlocal count
        i = 0
        while not stop:
            start = time.perf_counter_ns()
            counted = measuring
            await commit(w, i)
            i += 1
            if measuring:
                count += 1
                if counted:
                    latencies.append(time.perf_counter_ns() - start)

    async with anyio.create_task_group() as tg:
        for w in range(writers):
            tg.start_soon(writer, w)
        await anyio.sleep(warmup)
        on_window()
        measuring = True
        begin = time.perf_counter()
        await anyio.sleep(seconds)
        measuring = False
        window = time.perf_counter() - begin
        on_window()
        stop = True
    return count, window, latencies


async def inprocess_tps(bench: Bench, mode: DurabilityMode, writers: int) -> TxResult:
    """WmStore.transact with a data dir: validate, apply, log, fsync per ``mode``, publish."""
    data = bench.temp_dir(f"wm-{mode}-{writers}-")
    store = await WmStore.open(bench.ontology, StoreConfig(data_dir=str(data), durability=mode))
    try:
        async with anyio.create_task_group() as tg:
            await tg.start(store.run)
            adds: list[Op] = [AddElement(type="Gear", label=f"w{w}") for w in range(writers)]
            ids = list((await store.transact(Transact(ops=adds))).ids.values())
            durability = store._durability  # private: read only for the batch statistics
            assert durability is not None
            marks: list[DurabilityStats] = []
            cpu = CpuMeter({})

            def mark() -> None:
                marks.append(durability.statistics())
                cpu.mark()

            async def commit(w: int, i: int) -> object:
                op = UpdateElement(id=ids[w], properties={"mass": mass_at(w, i)})
                return await store.transact(
                    Transact(ops=[op], txn_id=uuid.uuid4().hex, author="bench")
                )

            plan = bench.plan
            count, window, lat = await drive_writers(
                commit,
                writers,
                plan.tx_warmup,
                plan.tx_seconds,
                mark,
            )
            tg.cancel_scope.cancel()
    finally:
        await store.aclose()
        shutil.rmtree(data, ignore_errors=True)
    return TxResult(
        "in-process",
        mode,
        writers,
        count,
        window,
        count / window,
        summarize(lat, 1e-6),
        logged=marks[1].commits - marks[0].commits,
        fsyncs=marks[1].fsyncs - marks[0].fsyncs,
        cpu_us_per_tx=cpu.per_tx(count),
    )


async def zenoh_tps(
    bench: Bench, wm: WmClient, writers: int, *, read_your_writes: bool = True
) -> TxResult:
    """WmClient.update_element: request -> router -> store (fsync, group) -> reply, then (the
    client's default) wait until the change is back in the writer's own replica."""
    ids = []
    run = wm.revision  # labels are unique: each run's writers are labelled apart
    for w in range(writers):
        ids.append(await wm.add_element("Gear", label=f"z{writers}-{w}@{run}"))

    async def commit(w: int, i: int) -> object:
        return await wm.update_element(ids[w], {"mass": mass_at(w, i)})

    plan = bench.plan
    cpu = CpuMeter(bench.pids)
    wm.read_your_writes = read_your_writes
    try:
        count, window, lat = await drive_writers(
            commit, writers, plan.tx_warmup, plan.zenoh_tx_seconds, cpu.mark
        )
    finally:
        wm.read_your_writes = True
    path = "zenoh" if read_your_writes else "zenoh, no read-your-writes"
    return TxResult(
        path,
        "group",
        writers,
        count,
        window,
        count / window,
        summarize(lat, 1e-6),
        cpu_us_per_tx=cpu.per_tx(count),
    )
