"""World-model benchmarks: durable transactions/s, change propagation, resolve on 10k elements.

    python benchmarks/wm.py            # full run (about 2 minutes on 2 cores)
    python benchmarks/wm.py --quick    # smoke run, < 60 s
    python benchmarks/wm.py --json results.json

Every figure is printed beside a baseline measured in the same run, with the ratio (method
and results: ``docs/benchmarks.md``):

1. durable tx/s of :class:`~wm_store.WmStore` (data dir in a temp folder) with durability
   ``group`` against ``fsync`` and ``none`` at 1, 16 and 64 concurrent writers, in-process;
   then through the whole Zenoh path (``WmClient`` -> router -> store process -> fsync ->
   change -> replica) against the in-process figure;
2. change propagation: publication by the store process -> ``on_change`` in a replica in a
   third process, one-way, on ``CLOCK_MONOTONIC`` (``time.monotonic_ns``, one clock for every
   process on Linux), against the raw Zenoh get round trip and the raw put -> subscriber time
   between two processes;
3. ``resolve`` on a 10k-element replica against the same questions in SPARQL
   (:class:`~wm_store.sparql.SparqlEngine` on rdflib).

Processes: a Zenoh router, an echo process (raw baselines), the store and a remote replica are
children of this script (``--role``), started with ``sys.executable``, listening or connecting
on 127.0.0.1 only (free port, multicast scouting off), stopped by PID; temp dirs are removed.
"""

from __future__ import annotations

import argparse
import contextlib
import json
import random
import shutil
import signal
import struct
import sys
import tempfile
import threading
import time
import uuid
from collections.abc import Awaitable, Callable, Sequence
from pathlib import Path
from typing import Any

import anyio
import msgspec
import zenoh

from benchmarks.common import (
    Child,
    Row,
    Stats,
    calibrate,
    child_router,
    cpu_seconds,
    emit,
    format_grid,
    format_table,
    load_average,
    machine_info,
    stdin_lines,
    summarize,
)
from meshlink import Answer, IncomingQuery, MeshConfig, open_mesh, to_zenoh_config
from meshlink.bridge import call0, undeclare
from meshlink.testing import free_port
from skimesh.runtime import run_service
from wm_store import (
    InMemoryTransport,
    Ontology,
    PropertyFilter,
    Query,
    Relation,
    StoreConfig,
    WmClient,
    WmService,
    WmStore,
    ZenohTransport,
    serve_store,
)
from wm_store.durability import DurabilityMode, DurabilityStats
from wm_store.protocol import AddElement, ClassDef, DefineClass, Op, Transact, UpdateElement
from wm_store.sparql import SparqlEngine

PAYLOAD = 200  # bytes of the raw baseline payloads (a small change is ~150-250 bytes)
MODES: tuple[DurabilityMode, ...] = ("fsync", "group", "none")
WRITERS = (1, 16, 64)
PART_CLASSES = ("Gear", "Shaft", "Bracket", "Bolt")  # in the core ontology
EXTRA_PART_CLASSES = ("Nut", "Washer", "Spring", "Pin", "Bearing", "Pulley")  # taught at run time


class Plan(msgspec.Struct, frozen=True, kw_only=True):
    """Counts and durations of one run."""

    raw_calls: int
    warmup_calls: int
    tx_warmup: float
    tx_seconds: float
    zenoh_tx_seconds: float
    changes: int
    resolve_calls: int
    sparql_calls: int
    sparql_seconds: float
    rounds: int  # of each tx/s configuration; the best round is reported


FULL = Plan(
    raw_calls=2000,
    warmup_calls=200,
    tx_warmup=0.5,
    tx_seconds=2.0,
    zenoh_tx_seconds=3.0,
    changes=1500,
    resolve_calls=2000,
    sparql_calls=200,
    sparql_seconds=4.0,
    rounds=2,
)
QUICK = Plan(
    raw_calls=500,
    warmup_calls=50,
    tx_warmup=0.2,
    tx_seconds=0.5,
    zenoh_tx_seconds=0.8,
    changes=300,
    resolve_calls=300,
    sparql_calls=20,
    sparql_seconds=0.8,
    rounds=1,
)


# =========================================================================== child roles


def raw_keys(mesh: str) -> tuple[str, str, str]:
    """Keys of the raw get, the raw put and the meshlink (anyio bridge) echo."""
    base = f"skimesh/{mesh}/bench"
    return f"{base}/rtt", f"{base}/oneway", f"{base}/rtt-bridge"


def child_echo(args: argparse.Namespace) -> int:
    """Raw Zenoh queryable (200-byte reply) and subscriber (one-way times), plus a meshlink
    queryable, all on one client session."""
    rtt_key, oneway_key, bridge_key = raw_keys(args.mesh)
    reply = bytes(PAYLOAD)
    delays: list[int] = []
    arrived = threading.Condition()

    def on_query(query: zenoh.Query) -> None:  # zenoh's thread for this queryable
        with query:
            query.reply(query.key_expr, reply)

    def on_sample(sample: zenoh.Sample) -> None:
        now = time.monotonic_ns()
        (sent,) = struct.unpack_from("<q", sample.payload.to_bytes())
        with arrived:
            delays.append(now - sent)
            arrived.notify_all()

    async def bridge_echo(query: IncomingQuery) -> list[Answer]:
        return [Answer(key=bridge_key, payload=reply)]

    def wait_for(count: int) -> list[int]:
        with arrived:
            arrived.wait_for(lambda: len(delays) >= count, timeout=10.0)
            got = list(delays)
            delays.clear()
            return got

    async def main() -> int:
        config = MeshConfig(connect=(args.connect,), mesh=args.mesh)
        async with open_mesh(config) as mesh, anyio.create_task_group() as tg:
            queryable = mesh.session.declare_queryable(rtt_key, on_query)
            subscriber = mesh.session.declare_subscriber(oneway_key, on_sample)
            try:
                await tg.start(mesh.serve, bridge_key, bridge_echo)  # also syncs with the router
                emit({"ready": True})
                async for line in stdin_lines():
                    command = json.loads(line)
                    got = await anyio.to_thread.run_sync(wait_for, command["expect"])
                    emit({"oneway": got[command["skip"] :], "received": len(got)})
            finally:
                undeclare(subscriber)
                undeclare(queryable)
                tg.cancel_scope.cancel()
        return 0

    return run_service(main)


def child_store(args: argparse.Namespace) -> int:
    """``skimesh wm`` (WmStore + serve_store), plus a listener that stamps each change with
    CLOCK_MONOTONIC just before the server's own listener publishes it."""
    published: list[tuple[int, int, int]] = []

    async def main() -> int:
        config = StoreConfig(data_dir=args.data, durability=args.durability)
        store = await WmStore.open(Ontology.default(), config)
        store.add_listener(lambda c, payload: published.append((c.revision, _now(), len(payload))))
        mesh_config = MeshConfig(connect=(args.connect,), mesh=args.mesh)
        async with open_mesh(mesh_config) as mesh, anyio.create_task_group() as tg:
            await tg.start(serve_store, mesh, store)
            emit({"ready": store.revision})
            async for line in stdin_lines():
                after = json.loads(line)["after"]
                emit({"stamps": [p for p in published if p[0] > after]})
            tg.cancel_scope.cancel()
        return 0

    return run_service(main)


def child_replica(args: argparse.Namespace) -> int:
    """A WmClient whose ``on_change`` stamps each applied change with CLOCK_MONOTONIC."""
    applied: list[tuple[int, int]] = []

    async def main() -> int:
        config = MeshConfig(connect=(args.connect,), mesh=args.mesh)
        async with open_mesh(config) as mesh, WmClient.connect(ZenohTransport(mesh)) as wm:
            wm.on_change(lambda change: applied.append((change.revision, _now())))
            emit({"ready": wm.revision})
            async for line in stdin_lines():
                command = json.loads(line)
                await wm.wait_for_revision(command["until"], timeout=30.0)
                emit({"stamps": [a for a in applied if a[0] > command["after"]]})
        return 0

    return run_service(main)


def _now() -> int:
    return time.monotonic_ns()


# =========================================================================== orchestration


class Bench:
    """One run: its plan, the children it started, its results."""

    def __init__(self, plan: Plan, data_root: Path, stack: contextlib.ExitStack) -> None:
        self.plan = plan
        self.data_root = data_root
        self.stack = stack
        self.mesh = f"bench-{uuid.uuid4().hex[:10]}"
        self.endpoint = ""
        self.pids: dict[str, int] = {}  # children whose CPU time the tx/s runs account
        self.ontology = Ontology.default()
        self.rows: list[Row] = []
        self.details: dict[str, Any] = {}

    def child(self, role: str, *args: str, ready_timeout: float = 60.0) -> Child:
        child = Child(["-m", "benchmarks.wm", "--role", role, *args], name=role)
        self.stack.callback(child.stop)
        child.expect("ready", timeout=ready_timeout)
        return child

    def temp_dir(self, prefix: str) -> Path:
        path = Path(tempfile.mkdtemp(prefix=prefix, dir=self.data_root))
        self.stack.callback(shutil.rmtree, path, ignore_errors=True)
        return path

    def start_router(self, attempts: int = 5) -> None:
        for attempt in range(attempts):
            endpoint = f"tcp/127.0.0.1:{free_port()}"
            try:
                self.pids["router"] = self.child("router", "--listen", endpoint).pid
            except RuntimeError:  # the port was taken meanwhile
                if attempt == attempts - 1:
                    raise
                continue
            self.endpoint = endpoint
            return

    def mesh_args(self) -> list[str]:
        return ["--connect", self.endpoint, "--mesh", self.mesh]

    def log(self, text: str) -> None:
        print(text, file=sys.stderr, flush=True)


# --------------------------------------------------------------------------- raw baselines


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


# --------------------------------------------------------------------------- tx/s


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


def _mass(w: int, i: int) -> float:
    return 0.1 + ((w * 7919 + i) % 1000) / 10_000


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
                op = UpdateElement(id=ids[w], properties={"mass": _mass(w, i)})
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
    for w in range(writers):
        ids.append(await wm.add_element("Gear", label=f"z{writers}-{w}"))

    async def commit(w: int, i: int) -> object:
        return await wm.update_element(ids[w], {"mass": _mass(w, i)})

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


# --------------------------------------------------------------------------- propagation


async def propagation(
    bench: Bench, wm: WmClient, store: Child, replica: Child
) -> tuple[Stats, Stats, int]:
    """Sequential single-op commits by this process; the store stamps each change as it
    publishes it, the replica process as its ``on_change`` runs. Returns (publish -> apply,
    commit call -> remote apply, payload bytes of one change)."""
    target = await wm.add_element("Gear", label="propagation")
    first = wm.revision
    started: dict[int, int] = {}
    for i in range(bench.plan.changes):
        start = _now()
        revision = await wm.update_element(target, {"mass": _mass(0, i)})
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


# --------------------------------------------------------------------------- resolve


class ResolveCase(msgspec.Struct):
    """One question asked of the replica (``resolve``) and of SPARQL, over rotating values."""

    name: str
    queries: list[Query]
    sparql: str
    bindings: list[dict[str, str]]


class ResolveResult(msgspec.Struct):
    name: str
    results: int  # matches of the first question
    agree: bool  # resolve and SPARQL gave the same ids for every question checked
    resolve: Stats  # µs, wall
    resolve_cpu: Stats  # µs, CPU time of the thread
    sparql: Stats  # µs, SparqlEngine.query (graph cached)
    rdflib: Stats  # µs, plain Graph.query with the prepared query


async def build_scene(ontology: Ontology) -> tuple[WmStore, list[str], list[str]]:
    """10,000 elements: 10 shelves contain 90 part boxes, each box contains 110 parts of one
    of 10 part classes (990 per class; 6 classes are taught at run time). Parts carry a mass
    and a part number. Returns the store (memory only), the part labels and the box ids."""
    rng = random.Random(7)
    store = await WmStore.open(ontology)
    define: list[Op] = [
        DefineClass(cls=ClassDef(name=n, parent="Part")) for n in EXTRA_PART_CLASSES
    ]
    await store.transact(Transact(ops=define))
    shelves: list[Op] = [
        AddElement(type="Shelf", label=f"shelf-{s}", ref=f"$s{s}") for s in range(10)
    ]
    shelf_ids = list((await store.transact(Transact(ops=shelves))).ids.values())
    labels: list[str] = []
    boxes: list[str] = []
    for c, cls in enumerate(PART_CLASSES + EXTRA_PART_CLASSES):
        for b in range(9):
            shelf = shelf_ids[(c * 9 + b) % len(shelf_ids)]
            ops: list[Op] = [
                AddElement(
                    type="PartBox",
                    label=f"box-{cls.lower()}-{b}",
                    ref="$box",
                    relations=[Relation(shelf, "contain", "$")],
                )
            ]
            for j in range(b * 110, (b + 1) * 110):
                label = f"{cls.lower()}-{j:04d}"
                labels.append(label)
                ops.append(
                    AddElement(
                        type=cls,
                        label=label,
                        properties={
                            "mass": round(rng.uniform(0.01, 0.5), 4),
                            "partNumber": f"PN-{cls}-{j % 50:02d}",
                        },
                        relations=[Relation("$box", "contain", "$")],
                    )
                )
            boxes.append((await store.transact(Transact(ops=ops))).ids["$box"])
    return store, labels, boxes


def resolve_cases(labels: Sequence[str], boxes: Sequence[str], rotate: int) -> list[ResolveCase]:
    rng = random.Random(11)
    classes = PART_CLASSES + EXTRA_PART_CLASSES
    picked_labels = rng.sample(list(labels), rotate)
    picked_boxes = [boxes[i % len(boxes)] for i in rng.sample(range(len(boxes)), min(rotate, 90))]
    light = PropertyFilter(property="mass", op="lt", value=0.06)
    return [
        ResolveCase(
            "type (leaf, ~1k) + filter mass < 0.06",
            [Query(type=c, filters=[light]) for c in classes],
            # skm:rev: scene elements only (the ontology's template individuals have types too);
            # 6e-2 is an xsd:double like the masses (rdflib compares a double with the
            # decimal 0.06 exactly, so a mass of 0.06 would pass "< 0.06")
            "SELECT ?e WHERE { ?e a ?type ; skm:rev ?rev ; skm:mass ?m . FILTER(?m < 6e-2) }",
            [{"type": f"skm:{c}"} for c in classes],
        ),
        ResolveCase(
            "label (unique)",
            [Query(label=label) for label in picked_labels],
            "SELECT ?e WHERE { ?e rdfs:label ?label }",
            [{"label": label} for label in picked_labels],
        ),
        ResolveCase(
            "type Part (subclasses) contained in a box",
            [Query(type="Part", related=[Relation(b, "contain", "?")]) for b in picked_boxes],
            "SELECT ?e WHERE { ?box skm:contain ?e . ?e a/rdfs:subClassOf* skm:Part }",
            [{"box": b} for b in picked_boxes],
        ),
    ]


def time_calls(
    call: Callable[[int], object], calls: int, budget: float, warmup: int
) -> tuple[list[int], list[int]]:
    """ns per ``call(i)``, wall (perf_counter) and this thread's CPU time: ``warmup`` untimed
    calls, then up to ``calls`` timed ones or until ``budget`` seconds have passed (at
    least 5). CPU time leaves out the time the process was descheduled by other load."""
    for i in range(warmup):
        call(i)
    wall: list[int] = []
    cpu: list[int] = []
    deadline = time.perf_counter() + budget
    for i in range(calls):
        start, start_cpu = time.perf_counter_ns(), time.thread_time_ns()
        call(i)
        cpu.append(time.thread_time_ns() - start_cpu)
        wall.append(time.perf_counter_ns() - start)
        if i >= 4 and time.perf_counter() > deadline:
            break
    return wall, cpu


async def resolve_bench(bench: Bench) -> tuple[list[ResolveResult], float, int, int]:
    """Returns the per-question results, the graph build time (s), triples, elements.

    ``resolve`` is timed first, while no rdflib graph exists in the process (as in an agent,
    whose replica never builds one): the graph's ~10^6 objects would lengthen every garbage
    collection pass and so the resolve tail."""
    plan = bench.plan
    store, labels, boxes = await build_scene(bench.ontology)
    async with WmClient.connect(InMemoryTransport(WmService(store))) as wm:
        state, ontology = wm.replica.state, wm.ontology
        cases = resolve_cases(labels, boxes, rotate=50)
        resolve_ns: list[tuple[list[int], list[int]]] = []
        for case in cases:

            def run_resolve(i: int, queries: list[Query] = case.queries) -> object:
                return wm.resolve_element(queries[i % len(queries)])

            resolve_ns.append(time_calls(run_resolve, plan.resolve_calls, 30.0, 50))

        engine = SparqlEngine()
        start = time.perf_counter()
        graph = engine.graph(state, ontology)
        build = time.perf_counter() - start
        results = []
        for case, resolve_samples in zip(cases, resolve_ns, strict=True):
            agree = True
            for q, b in zip(case.queries[:10], case.bindings[:10], strict=True):
                mine = sorted(e.id for e in wm.resolve_element(q))
                reply = engine.query(state, ontology, case.sparql, b)
                agree = agree and mine == sorted(str(row[0]) for row in reply.rows)

            def run_sparql(i: int, case: ResolveCase = case) -> object:
                bindings = case.bindings[i % len(case.bindings)]
                return engine.query(state, ontology, case.sparql, bindings)

            prepared = engine.prepare(case.sparql, ontology)
            inits = [_rdflib_bindings(ontology, b) for b in case.bindings]

            def run_rdflib(i: int, prepared: Any = prepared, inits: Any = inits) -> object:
                return list(graph.query(prepared, initBindings=inits[i % len(inits)]))

            sparql_ns, _ = time_calls(run_sparql, plan.sparql_calls, plan.sparql_seconds, 2)
            rdflib_ns, _ = time_calls(run_rdflib, plan.sparql_calls, plan.sparql_seconds, 2)
            results.append(
                ResolveResult(
                    case.name,
                    len(wm.resolve_element(case.queries[0])),
                    agree,
                    summarize(resolve_samples[0], 1e-3),
                    summarize(resolve_samples[1], 1e-3),
                    summarize(sparql_ns, 1e-3),
                    summarize(rdflib_ns, 1e-3),
                )
            )
        return results, build, len(graph), len(state.elements)


def _rdflib_bindings(ontology: Ontology, bindings: dict[str, str]) -> dict[str, Any]:
    from rdflib import Literal

    from wm_store.rdf import SCENE

    out: dict[str, Any] = {}
    for name, value in bindings.items():
        if value.startswith("skm:"):
            out[name] = ontology.namespace[value[4:]]
        elif name == "box":
            out[name] = SCENE[value]
        else:
            out[name] = Literal(value)
    return out


# --------------------------------------------------------------------------- the run


def filesystem_of(path: Path) -> str:
    """``<fstype> on <device>`` of the mount holding ``path`` (Linux /proc/mounts)."""
    best = ("", "?", "?")
    try:
        mounts = Path("/proc/mounts").read_text().splitlines()
    except OSError:
        return "?"
    resolved = str(path.resolve())
    for line in mounts:
        device, mount, fstype, *_ = line.split()
        inside = resolved == mount or resolved.startswith(mount.rstrip("/") + "/")
        if inside and len(mount) >= len(best[0]):
            best = (mount, fstype, device)
    return f"{best[1]} on {best[2]} (mounted at {best[0]})"


async def async_phases(bench: Bench, echo: Child) -> None:
    plan, details = bench.plan, bench.details
    bench.log("meshlink request round trip (anyio bridge on both ends)...")
    details["bridge_rtt_us"] = await bridge_rtt(bench)
    await anyio.to_thread.run_sync(echo.stop)

    runs: list[TxResult] = []
    for rnd in range(plan.rounds):
        for writers in WRITERS:
            for mode in MODES:  # interleaved, so a slow spell of the disk hits every mode
                bench.log(f"in-process durable tx/s: {mode}, {writers} writer(s), round {rnd + 1}")
                runs.append(await inprocess_tps(bench, mode, writers))

    bench.log("store process (durability group) and Zenoh tx/s...")
    data = bench.temp_dir("wm-store-")
    args = [*bench.mesh_args(), "--data", str(data), "--durability", "group"]
    store = await anyio.to_thread.run_sync(lambda: bench.child("store", *args))
    bench.pids["store"] = store.pid
    config = MeshConfig(connect=(bench.endpoint,), mesh=bench.mesh)
    async with open_mesh(config) as mesh, WmClient.connect(ZenohTransport(mesh)) as wm:
        for rnd in range(plan.rounds):
            for writers in WRITERS:
                bench.log(f"Zenoh durable tx/s: group, {writers} writer(s), round {rnd + 1}")
                runs.append(await zenoh_tps(bench, wm, writers))
        for writers in WRITERS[1:]:  # where the time goes: the same without the replica wait
            bench.log(f"Zenoh durable tx/s: group, {writers} writer(s), no read-your-writes")
            runs.append(await zenoh_tps(bench, wm, writers, read_your_writes=False))
        bench.log(f"change propagation to a replica process ({plan.changes} changes)...")
        replica = await anyio.to_thread.run_sync(lambda: bench.child("replica", *bench.mesh_args()))
        one_way, end_to_end, size = await propagation(bench, wm, store, replica)
    await anyio.to_thread.run_sync(replica.stop)
    await anyio.to_thread.run_sync(store.stop)
    del bench.pids["store"]
    tx: dict[tuple[str, str, int], TxResult] = {}
    for r in runs:  # best of the rounds: noise from other load only ever slows a run down
        key = (r.path, r.mode, r.writers)
        if key not in tx or r.tps > tx[key].tps:
            tx[key] = r
    details["tx"] = sorted(tx.values(), key=lambda r: (r.path, MODES.index(r.mode), r.writers))
    details["tx_runs"] = runs
    details["propagation_us"] = one_way
    details["commit_to_remote_apply_us"] = end_to_end
    details["change_bytes"] = size

    bench.log("resolve vs SPARQL on 10k elements (building the scene)...")
    resolved, build, triples, elements = await resolve_bench(bench)
    details["resolve"] = resolved
    details["graph_build_s"] = build
    details["graph_triples"] = triples
    details["elements"] = elements
    bench.rows = make_rows(bench.details, tx)


def make_rows(details: dict[str, Any], tx: dict[tuple[str, str, int], TxResult]) -> list[Row]:
    rows: list[Row] = []
    for n in WRITERS:
        group = tx["in-process", "group", n]
        rows.append(
            Row(
                figure=f"durable tx/s, group commit, in-process, {n} writer(s)",
                value=group.tps,
                unit="tx/s",
                baseline="fsync",
                baseline_value=tx["in-process", "fsync", n].tps,
                target=">= 2,000" if n > 1 else "",
                met=group.tps >= 2000 if n > 1 else None,
            )
        )
        rows.append(
            Row(
                figure=f"  same, against the no-fsync ceiling, {n} writer(s)",
                value=group.tps,
                unit="tx/s",
                baseline="none",
                baseline_value=tx["in-process", "none", n].tps,
            )
        )
    for n in WRITERS:
        z = tx["zenoh", "group", n]
        rows.append(
            Row(
                figure=f"durable tx/s, group, via Zenoh (WmClient), {n} writer(s)",
                value=z.tps,
                unit="tx/s",
                baseline="in-process group",
                baseline_value=tx["in-process", "group", n].tps,
                target=">= 2,000" if n > 1 else "",
                met=z.tps >= 2000 if n > 1 else None,
            )
        )
    raw_rtt: Stats = details["raw_rtt_us"]
    one_way: Stats = details["propagation_us"]
    ratio = one_way.p50 / raw_rtt.p50
    rows += [
        Row(
            figure="change propagation p50 (store publish -> remote on_change)",
            value=one_way.p50,
            unit="µs",
            baseline="raw get RTT p50",
            baseline_value=raw_rtt.p50,
            target="<= 3x baseline",
            met=ratio <= 3.0,
        ),
        Row(
            figure="change propagation p99",
            value=one_way.p99,
            unit="µs",
            baseline="raw get RTT p99",
            baseline_value=raw_rtt.p99,
        ),
        Row(
            figure="change propagation p50, against raw one-way",
            value=one_way.p50,
            unit="µs",
            baseline="raw put->sub p50",
            baseline_value=details["raw_oneway_us"].p50,
        ),
        Row(
            figure="commit call -> remote on_change p50 (incl. fsync)",
            value=details["commit_to_remote_apply_us"].p50,
            unit="µs",
            baseline="raw get RTT p50",
            baseline_value=raw_rtt.p50,
        ),
        Row(
            figure="meshlink request RTT p50 (anyio bridge both ends)",
            value=details["bridge_rtt_us"].p50,
            unit="µs",
            baseline="raw get RTT p50",
            baseline_value=raw_rtt.p50,
        ),
    ]
    for r in details["resolve"]:
        for q in ("p50", "p99"):
            value = getattr(r.resolve, q)
            rows.append(
                Row(
                    figure=f"resolve {q}, 10k elements: {r.name}",
                    value=value,
                    unit="µs",
                    baseline=f"SPARQL {q}",
                    baseline_value=getattr(r.sparql, q),
                    target="< 1,000 µs" if q == "p50" else "",
                    met=(value < 1000.0 and r.agree) if q == "p50" else None,
                    note="" if r.agree else "resolve and SPARQL disagree",
                )
            )
    rows.append(
        Row(
            figure=f"SPARQL graph build, {details['elements']:,} elements",
            value=details["graph_build_s"] * 1e3,
            unit="ms",
        )
    )
    return rows


def detail_tables(details: dict[str, Any]) -> str:
    tx = format_grid(
        (
            "path",
            "durability",
            "writers",
            "tx/s",
            "commit p50 ms",
            "p99 ms",
            "tx per fsync",
            "CPU µs per tx: bench/router/store",
        ),
        [
            (
                t.path,
                t.mode,
                str(t.writers),
                f"{t.tps:,.0f}",
                f"{t.commit.p50:.2f}",
                f"{t.commit.p99:.2f}",
                f"{t.logged / t.fsyncs:.1f}" if t.fsyncs else "-",
                "/".join(f"{v:.0f}" for v in t.cpu_us_per_tx.values()),
            )
            for t in details["tx"]
        ],
    )
    lat = format_grid(
        ("latency (µs)", "count", "p50", "p90", "p99", "max"),
        [
            (name, str(s.count), f"{s.p50:.0f}", f"{s.p90:.0f}", f"{s.p99:.0f}", f"{s.max:.0f}")
            for name, s in (
                ("raw Zenoh get round trip", details["raw_rtt_us"]),
                ("raw Zenoh put -> subscriber (one way)", details["raw_oneway_us"]),
                ("meshlink request round trip", details["bridge_rtt_us"]),
                ("change: store publish -> remote on_change", details["propagation_us"]),
                ("change: commit call -> remote on_change", details["commit_to_remote_apply_us"]),
            )
        ],
    )
    res = format_grid(
        (
            "query (10k elements)",
            "hits",
            "agree",
            "resolve p50/p99",
            "resolve CPU p50/p99",
            "SPARQL p50/p99",
            "rdflib p50",
        ),
        [
            (
                r.name,
                str(r.results),
                "yes" if r.agree else "NO",
                f"{r.resolve.p50:.0f} / {r.resolve.p99:.0f} µs",
                f"{r.resolve_cpu.p50:.0f} / {r.resolve_cpu.p99:.0f} µs",
                f"{r.sparql.p50:,.0f} / {r.sparql.p99:,.0f} µs (n={r.sparql.count})",
                f"{r.rdflib.p50:,.0f} µs",
            )
            for r in details["resolve"]
        ],
    )
    extra = (
        f"one change on the wire: {details['change_bytes']} bytes; SPARQL graph: "
        f"{details['graph_triples']:,} triples built in {details['graph_build_s']:.2f} s"
    )
    return "\n\n".join([tx, lat, res, extra])


def _terminate(signum: int, _frame: object) -> None:
    raise SystemExit(128 + signum)  # unwinds the ExitStack: children stopped, temp dirs removed


def run(plan: Plan, data_root: Path, json_path: Path | None) -> int:
    signal.signal(signal.SIGTERM, _terminate)
    info = machine_info(("eclipse-zenoh", "rdflib", "msgspec", "anyio"))
    info["data_dir_fs"] = filesystem_of(data_root)
    conditions = {"load_start": load_average(), "calibration_ms_start": calibrate()}
    started = time.perf_counter()
    with contextlib.ExitStack() as stack:
        bench = Bench(plan, data_root, stack)
        bench.log(f"router, echo process (mesh {bench.mesh})...")
        bench.start_router()
        echo = bench.child("echo", *bench.mesh_args())
        bench.log(f"raw Zenoh baselines ({plan.raw_calls} gets, {plan.raw_calls} puts)...")
        raw_rtt, raw_oneway = raw_baselines(bench, echo)
        bench.details["raw_rtt_us"] = raw_rtt
        bench.details["raw_oneway_us"] = raw_oneway
        anyio.run(async_phases, bench, echo)
    elapsed = time.perf_counter() - started
    conditions |= {"load_end": load_average(), "calibration_ms_end": calibrate()}
    print("machine: " + ", ".join(f"{k} {v}" for k, v in info.items()))
    print(
        f"run: {'quick' if plan is QUICK else 'full'}, {elapsed:.0f} s; load average "
        f"{conditions['load_start']} at start, {conditions['load_end']} at end; Python "
        f"calibration loop {conditions['calibration_ms_start']:.1f} / "
        f"{conditions['calibration_ms_end']:.1f} ms (start / end; lower is faster)\n"
    )
    print(format_table(bench.rows))
    print()
    print(detail_tables(bench.details))
    if json_path is not None:
        doc = {
            "machine": info,
            "conditions": conditions,
            "plan": plan,
            "rows": bench.rows,
            "details": bench.details,
        }
        json_path.write_bytes(msgspec.json.format(msgspec.json.encode(doc)))
    return 0


def main(argv: Sequence[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--quick", action="store_true", help="short smoke run (< 60 s)")
    parser.add_argument("--json", type=Path, metavar="FILE", help="also write results as JSON")
    parser.add_argument(
        "--data-root",
        type=Path,
        default=Path(tempfile.gettempdir()),
        help="where the temporary data directories go (its disk decides the fsync cost; "
        "default: %(default)s)",
    )
    hidden = argparse.SUPPRESS
    parser.add_argument("--role", choices=("router", "echo", "store", "replica"), help=hidden)
    parser.add_argument("--listen", help=hidden)
    parser.add_argument("--connect", help=hidden)
    parser.add_argument("--mesh", help=hidden)
    parser.add_argument("--data", help=hidden)
    parser.add_argument("--durability", default="group", help=hidden)
    args = parser.parse_args(argv)
    roles: dict[str, Callable[[argparse.Namespace], int]] = {
        "router": child_router,
        "echo": child_echo,
        "store": child_store,
        "replica": child_replica,
    }
    if args.role:
        return roles[args.role](args)
    return run(QUICK if args.quick else FULL, args.data_root, args.json)


if __name__ == "__main__":
    sys.exit(main())
