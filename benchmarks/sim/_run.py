"""The simulation benchmark's results table, details and command line."""

from __future__ import annotations

import argparse
import sys
import tempfile
import time
from collections.abc import Sequence
from functools import partial
from pathlib import Path
from typing import Any

import anyio
import msgspec

from benchmarks.common import (
    Row,
    calibrate,
    child_router,
    format_table,
    load_average,
    machine_info,
)
from benchmarks.sim._client import child_client
from benchmarks.sim._fleet import child_fleet, measure_fleet
from benchmarks.sim._measure import measure
from benchmarks.sim._system import LAYOUTS
from benchmarks.sim._workload import WORKLOADS

DESCRIPTION = (
    "Simulation benchmark: each scenario with every robot and driver working, beside bare\n"
    "``mj_step`` of the same model driven by the same set-points, in the same run."
)


def make_rows(results: dict[str, dict[str, Any]]) -> list[Row]:
    rows: list[Row] = []
    for name, r in results.items():
        ok = sum(r["success"].values())
        for layout, f in r["layouts"].items():
            pairs = "/".join(f"{x:.2f}" for x in f["overheads"])
            rows.append(
                Row(
                    figure=f"{name}: wall ms per simulated s, full system, {layout}",
                    value=1e3 * f["full_wall_per_sim_s"],
                    unit="ms",
                    baseline="bare mj_step, same set-points",
                    baseline_value=1e3 * f["bare_wall_per_sim_s"],
                    target="< 2x",
                    met=f["overhead"] < 2.0,
                    note=f"median of {len(f['overheads'])} pairs' ratios: {pairs}",
                    paired_ratio=f["overhead"],
                )
            )
        first = r["layouts"][r["real_time_layout"]]
        rows += [
            Row(
                figure=f"{name}: real-time factor, fast mode, {r['real_time_layout']}",
                value=1.0 / first["full_wall_per_sim_s"],
                unit="x",
                baseline="bare at rest",
                baseline_value=1.0 / r["rest_wall_per_sim_s"],
            ),
            Row(
                figure=f"{name}: CPU of an idle world in real time, % of a core",
                value=100 * r["idle_real_time_cpu"],
                unit="%",
                baseline="bare stepping at rest, real time",
                baseline_value=100 * r["rest_wall_per_sim_s"],
            ),
            Row(
                figure=f"{name}: real-time factor, real-time mode, {r['real_time_layout']}",
                value=r["real_time_factor"],
                unit="x",
                target=">= 0.98, no slip",
                met=r["real_time_factor"] >= 0.98 and r["real_time_slips"] == 0,
            ),
            Row(
                figure=f"{name}: pick-and-place success",
                value=ok,
                unit=f"of {len(r['success'])}",
                target="all",
                met=ok == len(r["success"]),
            ),
            Row(
                figure=f"{name}: stop-to-halt, worst (simulated)",
                value=1e3 * max(r["stop_to_halt_s"]),
                unit="ms",
                target="< 500 ms",
                met=max(r["stop_to_halt_s"]) < 0.5,
            ),
        ]
    return rows


def fleet_rows(fleet: dict[str, Any]) -> list[Row]:
    """The fleet case: the worst round of each case (real time is judged by its worst)."""

    def worst(case: str) -> dict[str, Any]:
        return min(fleet["runs"][case], key=lambda r: (r["real_time_factor"], -r["slips"]))

    big, small, paced = worst("fleet"), worst("small"), worst("paced")
    n, rounds = fleet["robots"], len(fleet["runs"]["fleet"])
    note = f"worst of {rounds}; {fleet['seconds']:.0f} s windows"
    return [
        Row(
            figure=f"fleet: {n} robots driving, real-time factor (slips: {big['slips']})",
            value=big["real_time_factor"],
            unit="x",
            baseline=f"{small['robots']} robots driving (slips: {small['slips']})",
            baseline_value=small["real_time_factor"],
            target=">= 0.98, no slip",
            met=big["real_time_factor"] >= 0.98 and big["slips"] == 0,
            note=note,
        ),
        Row(
            figure=f"fleet: {n} robots driving, paced runs (slips: {paced['slips']})",
            value=paced["real_time_factor"],
            unit="x",
            baseline=f"{n} robots, a hand-off per batch",
            baseline_value=big["real_time_factor"],
            note=f"handover 1 s; {note}",
        ),
        Row(
            figure=f"fleet: {n} robots driving, CPU of the simulator's process, % of a core",
            value=100 * big["cpu"],
            unit="%",
            baseline=f"{small['robots']} robots",
            baseline_value=100 * small["cpu"],
            note=f"paced runs: {100 * paced['cpu']:.0f} %",
        ),
    ]


def print_details(results: dict[str, dict[str, Any]]) -> None:
    for name, r in results.items():
        halts = ", ".join(f"{1e3 * h:.0f}" for h in r["stop_to_halt_s"])
        print(
            f"{name}: success {r['success']}; stop-to-halt ms [{halts}]; "
            f".rrd {r['rrd_bytes'] / 1e6:.1f} MB"
        )
        for layout, f in r["layouts"].items():
            print(
                f"  {layout}: {f['sim_s']:.1f} s simulated; CPU ms per simulated s: this "
                f"process {1e3 * f['cpu_per_sim_s']:.1f}, client process "
                f"{1e3 * f['client_cpu_per_sim_s']:.1f}"
            )


def main(argv: Sequence[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=DESCRIPTION)
    parser.add_argument("--quick", action="store_true", help="short smoke run")
    parser.add_argument("--json", type=Path, metavar="FILE", help="also write results as JSON")
    parser.add_argument("--scenario", action="append", choices=sorted(WORKLOADS))
    parser.add_argument(
        "--repeat", type=int, metavar="N", help="fast runs (and replays) per scenario (9; quick: 1)"
    )
    parser.add_argument(
        "--layout",
        action="append",
        choices=LAYOUTS,
        help="where the client and the router run (repeatable; the first is the headline; "
        "default: deployed and in-process)",
    )
    parser.add_argument("--in-process", action="store_true", help="the single-process layout only")
    parser.add_argument(
        "--fleet",
        type=int,
        default=40,
        metavar="N",
        help="the fleet case: N robots driving at once in real time (default 40; 0: skip)",
    )
    parser.add_argument("--fleet-only", action="store_true", help="only the fleet case")
    parser.add_argument(
        "--sensor-period",
        type=float,
        default=0.5,
        metavar="S",
        help="the workload reads every sensor every S simulated seconds (0: never; default 0.5)",
    )
    hidden = argparse.SUPPRESS
    parser.add_argument("--role", choices=("client", "fleet-client", "router"), help=hidden)
    parser.add_argument("--robots", type=int, help=hidden)
    parser.add_argument("--listen", help=hidden)
    parser.add_argument("--connect", help=hidden)
    parser.add_argument("--mesh", help=hidden)
    parser.add_argument("--picks", type=int, help=hidden)
    args = parser.parse_args(argv)
    if args.role == "router":
        return child_router(args)
    if args.role == "fleet-client":
        return child_fleet(args)
    if args.role == "client":
        args.scenario = args.scenario[0]
        return child_client(args)
    repeat = max(1, args.repeat or (1 if args.quick else 9))
    layouts = ["in-process"] if args.in_process else args.layout or ["deployed", "in-process"]
    info = machine_info(("mujoco", "rerun-sdk", "eclipse-zenoh", "placo"))
    conditions = {"load_start": load_average(), "calibration_ms_start": calibrate()}
    started = time.perf_counter()
    results: dict[str, dict[str, Any]] = {}
    with tempfile.TemporaryDirectory(prefix="skimesh-bench-sim-") as tmp:
        for name in [] if args.fleet_only else args.scenario or sorted(WORKLOADS):
            print(f"{name}: measuring...", file=sys.stderr, flush=True)
            run = partial(measure, period=args.sensor_period)
            results[name] = anyio.run(run, name, args.quick, repeat, layouts, Path(tmp))
        fleet: dict[str, Any] | None = None
        if args.fleet > 0:
            print(f"fleet of {args.fleet}: measuring...", file=sys.stderr, flush=True)
            seconds, rounds = (5.0, 1) if args.quick else (20.0, 2)
            fleet = anyio.run(measure_fleet, args.fleet, seconds, rounds, Path(tmp))
    conditions |= {"load_end": load_average(), "calibration_ms_end": calibrate()}
    rows = make_rows(results) + (fleet_rows(fleet) if fleet else [])
    print("machine: " + ", ".join(f"{k} {v}" for k, v in info.items()))
    print(
        f"run: {'quick' if args.quick else 'full'}, {time.perf_counter() - started:.0f} s; load "
        f"average {conditions['load_start']} at start, {conditions['load_end']} at end\n"
    )
    print(format_table(rows))
    print_details(results)
    for case, runs in (fleet or {}).get("runs", {}).items():
        found = ", ".join(
            f"{r['real_time_factor']:.3f} ({r['slips']} slips, CPU {100 * r['cpu']:.0f} %)"
            for r in runs
        )
        print(f"fleet, {case} ({runs[0]['robots']} robots): real-time factor {found}")
    if args.json is not None:
        doc = {"machine": info, "conditions": conditions, "rows": rows, "results": results}
        doc["fleet"] = fleet
        args.json.write_bytes(msgspec.json.format(msgspec.json.encode(doc)))
    return 0 if all(row.met is not False for row in rows) else 1
