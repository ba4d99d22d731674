"""A store no SPARQL request can stall: read and write latency with hostile queries in flight.

    python -m benchmarks.wm.hostile            # 2,000 reads and 2,000 writes per phase
    python -m benchmarks.wm.hostile --quick    # 200

Every part runs in a process of its own, as on a site: a Zenoh router (127.0.0.1, a free port,
multicast off), the store as ``skimesh wm`` runs it (2,000 elements, in memory), the attacker
(``--role attacker``) and this process, the timing client, which holds nothing but its own
session: reads (``GetElements`` of one element) and writes (one ``UpdateElement``) go to
``wm/rpc`` one after the other, each timed, in two phases of the same run:

- **quiet**: nothing else;
- **hostile**: the attacker keeps 8 SPARQL requests in flight, half runaway queries (a COUNT
  over a three-way cross join of every triple) and half malformed texts just under the size
  limit (16 KiB of open braces), each sent again as soon as it is answered or refused.

The phases alternate in ``--rounds`` rounds (quiet, then hostile, each ``1/rounds`` of the
requests; a quiet block starts once every hostile request of the round before came back), so
both meet the same load of the rest of the machine. The figure is each p99 under load against
its quiet p99 (target: within 2x). The store runs SPARQL in a worker process with a time limit
(``--sparql-timeout``, 2 s here) and stops it while it serves other requests, so a runaway
costs a child process, never the store's loop. Results: docs/benchmarks.md, section "A store
no request can stall".
"""

from __future__ import annotations

import argparse
import contextlib
import json
import os
import tempfile
import time
import uuid
from pathlib import Path

import anyio

from benchmarks.common import (
    Child,
    Row,
    child_router,
    emit,
    format_table,
    machine_info,
    stdin_lines,
    summarize,
)
from meshlink import MeshConfig, open_mesh
from meshlink.testing import free_port
from wm_store import WmClient, WmError, ZenohTransport
from wm_store.protocol import AddElement, GetElements, Sparql, Transact, UpdateElement

RUNAWAY = "SELECT (COUNT(*) AS ?n) WHERE { ?a ?b ?c . ?d ?e ?f . ?g ?h ?i }"
MALFORMED = "SELECT * WHERE " + "{" * (16 * 1024 - 40)
HOSTILE = 8
STORE = ("-m", "skimesh", "wm", "--durability", "none", "--sparql-timeout", "2")
_ROLE = ("-m", "benchmarks.wm.hostile", "--role")


async def timed(wm: WmClient, count: int, ids: list[str], start: int = 0) -> list[list[float]]:
    """``count`` reads and writes, one after the other: [read times, write times] (s)."""
    reads, writes = [], []
    for i in range(start, start + count):
        element = ids[i % len(ids)]
        began = time.perf_counter()
        await wm.request(GetElements(ids=[element]))
        reads.append(time.perf_counter() - began)
        began = time.perf_counter()
        op = UpdateElement(id=element, properties={"mass": 0.1 + (i % 7) / 100})
        await wm.request(Transact(ops=[op]))
        writes.append(time.perf_counter() - began)
    return [reads, writes]


def run_queue_wait(pid: int) -> float:
    """Seconds the threads of process ``pid`` have waited for a processor while runnable
    (``/proc/<pid>/task/*/schedstat``, Linux; 0 elsewhere)."""
    total = 0
    for stat in Path(f"/proc/{pid}/task").glob("*/schedstat"):
        with contextlib.suppress(OSError, ValueError, IndexError):
            total += int(stat.read_text().split()[1])
    return total / 1e9


Waits = dict[str, dict[str, float]]
"""Per phase (quiet, hostile), per process: seconds waited for a processor."""


async def phases(
    config: MeshConfig, attacker: Child, pids: dict[str, int], count: int, rounds: int
) -> tuple[list[list[float]], Waits]:
    """[quiet reads, quiet writes, hostile reads, hostile writes] over ``rounds`` rounds, and
    what the processes ``pids`` waited for a processor in each phase."""
    out: list[list[float]] = [[], [], [], []]
    waits: Waits = {phase: dict.fromkeys(pids, 0.0) for phase in ("quiet", "hostile")}

    async def block(
        phase: str, wm: WmClient, n: int, ids: list[str], start: int
    ) -> list[list[float]]:
        before = {name: run_queue_wait(pid) for name, pid in pids.items()}
        samples = await timed(wm, n, ids, start)
        for name, pid in pids.items():
            waits[phase][name] += run_queue_wait(pid) - before[name]
        return samples

    async with open_mesh(config) as mesh, WmClient.connect(ZenohTransport(mesh)) as wm:
        ops = [
            AddElement(type="Gear", label=f"g{i}", properties={"mass": 0.1}) for i in range(2000)
        ]
        reply = await wm.transact(list(ops))
        ids = sorted(v for k, v in reply.ids.items() if k.startswith("#"))
        await wm.request(Sparql(query="ASK { ?s ?p ?o }"))  # the worker is up
        n = max(count // rounds, 1)
        for r in range(rounds):
            quiet = await block("quiet", wm, n, ids, 2 * r * n)
            attacker.send({"attack": True})
            await attacker.expect_async("attacking")
            await anyio.sleep(1.0)  # every hostile request in flight
            loaded = await block("hostile", wm, n, ids, (2 * r + 1) * n)
            attacker.send({"attack": False})
            await attacker.expect_async("idle", timeout=180.0)  # the store has no query left
            for i, samples in enumerate([*quiet, *loaded]):
                out[i] += samples
    return out, waits


def _start_store(endpoint: str, mesh: str, data: str) -> Child:
    store = Child([*STORE, "--connect", endpoint, "--mesh", mesh, "--data", data], name="store")
    deadline = time.monotonic() + 60
    while "world model ready" not in store.log():
        if store.proc.poll() is not None or time.monotonic() > deadline:
            store.stop()
            raise RuntimeError(f"the store did not start\n{store.log()}")
        time.sleep(0.05)
    return store


def run(count: int, rounds: int) -> list[Row]:
    mesh = f"bench-{uuid.uuid4().hex[:8]}"
    endpoint = f"tcp/127.0.0.1:{free_port()}"
    config = MeshConfig(connect=(endpoint,), mesh=mesh)
    with contextlib.ExitStack() as stack:
        router = stack.enter_context(Child([*_ROLE, "router", "--listen", endpoint], name="router"))
        router.expect("ready")
        tmp = stack.enter_context(tempfile.TemporaryDirectory())
        store = stack.enter_context(_start_store(endpoint, mesh, tmp))
        attacker = Child(
            [*_ROLE, "attacker", "--connect", endpoint, "--mesh", mesh], name="attacker"
        )
        stack.enter_context(attacker)
        attacker.expect("connected")
        pids = {"store": store.pid, "router": router.pid, "client": os.getpid()}
        (qr, qw, hr, hw), waits = anyio.run(phases, config, attacker, pids, count, rounds)
        attacker.send({"report": True})
        answered = int(attacker.expect("answered")["answered"])
    rows: list[Row] = []
    for name, q, h in (("read", qr, hr), ("write", qw, hw)):
        qs, hs = summarize(q, 1e3), summarize(h, 1e3)
        rows.append(
            Row(figure=f"{name} p99, quiet", value=qs.p99, unit="ms", note=f"p50 {qs.p50:.2f} ms")
        )
        rows.append(
            Row(
                figure=f"{name} p99, {HOSTILE} hostile SPARQL in flight",
                value=hs.p99,
                unit="ms",
                baseline="quiet p99",
                baseline_value=qs.p99,
                target="<= 2x",
                met=hs.p99 <= 2 * qs.p99,
                note=f"p50 {hs.p50:.2f} ms",
            )
        )
    rows.append(Row(figure="hostile requests answered or refused", value=answered, unit=""))
    pairs = len(qr)  # a read and a write
    for name in pids:
        quiet, hostile = (waits[phase][name] / pairs * 1e6 for phase in ("quiet", "hostile"))
        rows.append(
            Row(
                figure=f"{name}: waited for a processor per read+write, hostile",
                value=hostile,
                unit="us",
                baseline="quiet",
                baseline_value=quiet,
            )
        )
    return rows


def child_attacker(args: argparse.Namespace) -> int:
    """The attacker (``--role attacker``): on ``{"attack": true}`` keeps :data:`HOSTILE` SPARQL
    requests in flight (says ``attacking``); on ``{"attack": false}`` sends no more and says
    ``idle`` once every one came back; ``{"report": true}``: how many came back in all."""
    from skimesh.runtime import run_service

    async def main() -> int:
        answered = in_flight = 0
        go = anyio.Event()  # set while attacking; a fresh one when told to stop
        drained = anyio.Event()  # set when the last request in flight came back

        async def attack(wm: WmClient, text: str) -> None:
            nonlocal answered, in_flight, drained
            while True:
                await go.wait()
                in_flight += 1
                try:
                    with contextlib.suppress(WmError):  # refused or ended: what it gets
                        await wm.request(Sparql(query=text))
                finally:
                    in_flight -= 1
                    answered += 1
                    if not in_flight:
                        drained.set()

        config = MeshConfig(connect=(args.connect,), mesh=args.mesh)
        async with open_mesh(config) as mesh, anyio.create_task_group() as tg:
            wm = WmClient(ZenohTransport(mesh), timeout=120.0)
            for i in range(HOSTILE):
                tg.start_soon(attack, wm, RUNAWAY if i % 2 == 0 else MALFORMED)
            emit({"connected": True})
            async for line in stdin_lines():
                command = json.loads(line)
                if command.get("attack") is True:
                    go.set()
                    emit({"attacking": HOSTILE})
                elif command.get("attack") is False:
                    go = anyio.Event()
                    if in_flight:  # what the store still holds comes back
                        drained = anyio.Event()
                        await drained.wait()
                    emit({"idle": answered})
                elif command.get("report"):
                    emit({"answered": answered})
            tg.cancel_scope.cancel()
        return 0

    return run_service(main)


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--quick", action="store_true", help="200 reads and writes per phase")
    parser.add_argument("--rounds", type=int, default=0, help="quiet/hostile rounds (4; quick 2)")
    hidden = argparse.SUPPRESS
    parser.add_argument("--role", choices=("router", "attacker"), help=hidden)
    parser.add_argument("--listen", help=hidden)
    parser.add_argument("--connect", help=hidden)
    parser.add_argument("--mesh", help=hidden)
    args = parser.parse_args()
    if args.role == "router":
        return child_router(args)
    if args.role == "attacker":
        return child_attacker(args)
    rows = run(200 if args.quick else 2000, args.rounds or (2 if args.quick else 4))
    print(machine_info())
    print(format_table(rows))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
