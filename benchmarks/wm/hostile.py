"""A store no SPARQL request can stall: read and write latency with hostile queries in flight.

    python -m benchmarks.wm.hostile            # 2,000 reads and 2,000 writes per phase
    python -m benchmarks.wm.hostile --quick    # 100

The store runs as ``skimesh wm`` does, in a process of its own (2,000 elements, in memory),
behind a Zenoh router in this process (127.0.0.1, a free port, multicast off). This process
is its client: reads (``GetElements`` of one element) and writes (one ``UpdateElement``) go to
``wm/rpc`` one after the other, each timed, in two phases of the same run:

- **quiet**: nothing else;
- **hostile**: 8 SPARQL requests kept in flight the whole time by a second session, half
  runaway queries (a COUNT over a three-way cross join of every triple) and half malformed
  texts just under the size limit (16 KiB of open braces), each sent again as soon as it is
  answered or refused.

The figure is each p99 under load against its quiet p99 (target: within 2x). The store runs
SPARQL in a worker process with a time limit (``--sparql-timeout``, 2 s here), so a runaway
costs a child process, never the store's loop. Results: docs/benchmarks.md, section "A store
no request can stall".
"""

from __future__ import annotations

import argparse
import contextlib
import subprocess
import sys
import tempfile
import time
import uuid

import anyio

from benchmarks.common import ROOT, Row, format_table, machine_info, summarize
from meshlink import MeshConfig, open_mesh
from meshlink.testing import running_router
from wm_store import WmClient, WmError, ZenohTransport
from wm_store.protocol import (
    AddElement,
    GetElements,
    Sparql,
    Transact,
    UpdateElement,
)

RUNAWAY = "SELECT (COUNT(*) AS ?n) WHERE { ?a ?b ?c . ?d ?e ?f . ?g ?h ?i }"
MALFORMED = "SELECT * WHERE " + "{" * (16 * 1024 - 40)
HOSTILE = 8
STORE = (sys.executable, "-m", "skimesh", "wm", "--durability", "none", "--sparql-timeout", "2")


async def timed(wm: WmClient, count: int, ids: list[str]) -> tuple[list[float], list[float]]:
    reads, writes = [], []
    for i in range(count):
        element = ids[i % len(ids)]
        start = time.perf_counter()
        await wm.request(GetElements(ids=[element]))
        reads.append(time.perf_counter() - start)
        start = time.perf_counter()
        op = UpdateElement(id=element, properties={"mass": 0.1 + (i % 7) / 100})
        await wm.request(Transact(ops=[op]))
        writes.append(time.perf_counter() - start)
    return reads, writes


async def phases(config: MeshConfig, count: int) -> tuple[list[list[float]], int]:
    answered = 0
    async with open_mesh(config) as mesh, WmClient.connect(ZenohTransport(mesh)) as wm:
        ops = [
            AddElement(type="Gear", label=f"g{i}", properties={"mass": 0.1}) for i in range(2000)
        ]
        reply = await wm.transact(list(ops))
        ids = sorted(v for k, v in reply.ids.items() if k.startswith("#"))
        await wm.request(Sparql(query="ASK { ?s ?p ?o }"))  # the worker is up
        quiet = await timed(wm, count, ids)
        async with open_mesh(config) as other:
            hostile = WmClient(ZenohTransport(other), timeout=60.0)

            async def attack(text: str) -> None:
                nonlocal answered
                while True:
                    with contextlib.suppress(WmError):  # refused or ended: what it gets
                        await hostile.request(Sparql(query=text))
                    answered += 1

            async with anyio.create_task_group() as load:
                for i in range(HOSTILE):
                    load.start_soon(attack, RUNAWAY if i % 2 == 0 else MALFORMED)
                await anyio.sleep(1.0)  # every hostile request in flight
                loaded = await timed(wm, count, ids)
                load.cancel_scope.cancel()
    return [*quiet, *loaded], answered


def run(count: int) -> list[Row]:
    mesh = f"bench-{uuid.uuid4().hex[:8]}"
    with running_router() as endpoint, tempfile.TemporaryDirectory() as tmp:
        store = subprocess.Popen(
            [*STORE, "--connect", endpoint, "--mesh", mesh, "--data", tmp],
            cwd=ROOT,
            stderr=subprocess.PIPE,
            text=True,
        )
        try:
            assert store.stderr is not None
            for line in store.stderr:
                if "world model ready" in line:
                    break
            config = MeshConfig(connect=(endpoint,), mesh=mesh)
            (qr, qw, hr, hw), answered = anyio.run(phases, config, count)
        finally:
            store.terminate()
            store.wait(10)
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
    return rows


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--quick", action="store_true", help="100 reads and writes per phase")
    args = parser.parse_args()
    rows = run(100 if args.quick else 2000)
    print(machine_info())
    print(format_table(rows))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
