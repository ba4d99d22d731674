"""The world-model benchmark's results table and detail tables."""

from __future__ import annotations

from typing import Any

from benchmarks.common import (
    Row,
    Stats,
    format_grid,
)
from benchmarks.wm._bench import WRITERS
from benchmarks.wm._tx import TxResult


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
