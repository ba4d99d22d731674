"""The skill benchmark's results table, the run in order and the command line."""

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

from benchmarks.common import (
    Child,
    Row,
    Stats,
    calibrate,
    child_router,
    format_table,
    load_average,
    machine_info,
    start_router_child,
)
from benchmarks.skills._measure import measured_phases, raw_rtt
from benchmarks.skills._setup import BREAKDOWN, CALLERS, FULL, QUICK, Plan, child_agent, child_store

DESCRIPTION = (
    "Skill-layer benchmarks: the round trip of a no-op skill run, and runs/s with concurrent "
    "callers."
)


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
    parser = argparse.ArgumentParser(description=DESCRIPTION)
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
