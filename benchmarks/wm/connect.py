"""What connecting with the store's ontology adds to a client's start-up.

    python -m benchmarks.wm.connect            # 40 connects per case
    python -m benchmarks.wm.connect --quick    # 8

A client takes the store's ontology when it connects: the snapshot carries the store's
ontology log (what was taught beyond the core, in order), which the client replays on its core
(:func:`wm_store.ontology.replay`: parse + compile of every taught Turtle text). A client whose
core file differs from the store's fetches the store's core first. Each case is the time of
``WmClient.connect`` until the replica is loaded, in-process over the in-memory transport (so
no network time hides the ontology's), against the same connect to a store that was taught
nothing, measured in the same run, interleaved case by case:

- ``site terms``: a site's few files (two part classes, a data property, a relation);
- ``large terms``: 300 classes and 100 data properties taught in 10 files;
- ``other core``: the store runs a core that differs from the client's file.

The figures are in docs/benchmarks.md, section "The store's ontology at connect".
"""

from __future__ import annotations

import argparse
import time

import anyio

from benchmarks.common import Row, format_table, machine_info, summarize
from wm_store import InMemoryTransport, WmClient
from wm_store.ontology import Ontology, core_ontology_path, property_turtle, relation_turtle
from wm_store.server import WmService, WmStore

PREFIXES = (
    "@prefix skm: <https://skimesh.dev/ontology#> .\n"
    "@prefix owl: <http://www.w3.org/2002/07/owl#> .\n"
    "@prefix rdfs: <http://www.w3.org/2000/01/rdf-schema#> .\n"
)


def site_terms() -> list[str]:
    classes = PREFIXES + "".join(
        f'skm:{name} a owl:Class ; rdfs:subClassOf skm:Part ; rdfs:label "{name}"@en .\n'
        for name in ("Bearing", "Pulley")
    )
    return [
        classes,
        property_turtle("inspected", kind="bool", domain=["Part"]),
        relation_turtle("heldBy", domain=["Pulley"], range=["Bearing"]),
    ]


def large_terms() -> list[str]:
    files = []
    for f in range(10):
        body = "".join(
            f"skm:Kind{f}x{i} a owl:Class ; rdfs:subClassOf skm:Part ; "
            f'rdfs:comment "generated class {i} of file {f}"@en .\n'
            for i in range(30)
        )
        files.append(PREFIXES + body)
        for i in range(10):
            files.append(property_turtle(f"measure{f}x{i}", kind="float", domain=["Part"]))
    return files


async def connect_times(store: WmStore, count: int) -> list[float]:
    service = WmService(store)
    samples = []
    for _ in range(count):
        start = time.perf_counter()
        async with WmClient.connect(InMemoryTransport(service)):
            samples.append(time.perf_counter() - start)
    return samples


async def taught_store(texts: list[str], base: Ontology | None = None) -> WmStore:
    store = WmStore(base or Ontology.default())
    async with anyio.create_task_group() as tg:
        await tg.start(store.run)
        for i, text in enumerate(texts):
            await store.teach(text, f"file-{i}")
        tg.cancel_scope.cancel()
    return store


async def main_async(count: int) -> list[Row]:
    other = Ontology.load(
        core_ontology_path().read_text() + "\nskm:Extra a owl:Class ; rdfs:subClassOf skm:Part .\n"
    )
    stores = {
        "nothing taught": await taught_store([]),
        "site terms": await taught_store(site_terms()),
        "large terms": await taught_store(large_terms()),
        "other core": await taught_store([], other),
    }
    samples: dict[str, list[float]] = {name: [] for name in stores}
    for _ in range(count):  # interleaved: drift on a shared machine hits every case alike
        for name, store in stores.items():
            samples[name] += await connect_times(store, 1)
    core = []
    for _ in range(max(3, count // 4)):  # what every client pays anyway: the core file's load
        start = time.perf_counter()
        Ontology.load(core_ontology_path())
        core.append(time.perf_counter() - start)
    base = summarize(samples["nothing taught"], 1e3)
    load = summarize(core, 1e3)
    rows = [
        Row(figure="connect, nothing taught", value=base.p50, unit="ms"),
        Row(figure="loading the core file (every process)", value=load.p50, unit="ms"),
    ]
    for name in ("site terms", "large terms", "other core"):
        stats = summarize(samples[name], 1e3)
        rows.append(
            Row(
                figure=f"connect, {name}: added",
                value=stats.p50 - base.p50,
                unit="ms",
                baseline="core load",
                baseline_value=load.p50,
                note=f"connect p90 {stats.p90:.1f} ms",
            )
        )
    return rows


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--quick", action="store_true", help="8 connects per case")
    args = parser.parse_args()
    rows = anyio.run(main_async, 8 if args.quick else 40)
    print(machine_info())
    print(format_table(rows))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
