"""Measure the start-up of ``skimesh`` commands against ``python -c pass`` (fresh processes)."""

from __future__ import annotations

import argparse
import contextlib
import os
import subprocess
import sys
import time
from collections.abc import Mapping, Sequence
from pathlib import Path

import msgspec

from benchmarks.cli._site import loopback_site
from benchmarks.common import (
    ROOT,
    Row,
    Stats,
    format_table,
    load_average,
    machine_info,
    summarize,
)
from meshlink.testing import free_port

__all__ = ["COMMANDS", "main", "measure"]

DESCRIPTION = "Start-up time of the skimesh command (see benchmarks/cli/__init__.py)."
BASELINE = "python -c pass"
TARGET_S = 0.5

#: What is run, by figure name: the interpreter's arguments.
COMMANDS: Mapping[str, Sequence[str]] = {
    BASELINE: ["-c", "pass"],
    "skimesh --help": ["-m", "skimesh", "--help"],
    "skimesh --version": ["-m", "skimesh", "--version"],
    "skimesh agents --help": ["-m", "skimesh", "agents", "--help"],
}

#: The light commands that ask a live mesh (``_site``), by figure name: their arguments (the
#: connection flags follow) and their exit code (a task id nobody has: refused, after the task
#: agent's answer).
CONNECTED: Mapping[str, tuple[Sequence[str], int]] = {
    "skimesh agents": (["-m", "skimesh", "agents"], 0),
    "skimesh skills r1": (["-m", "skimesh", "skills", "r1"], 0),
    "skimesh wm get Gear-1": (["-m", "skimesh", "wm", "get", "Gear-1"], 0),
    "skimesh task status t-none": (["-m", "skimesh", "task", "status", "t-none"], 2),
}

HEAVY = ("unified_planning", "mujoco", "placo", "rerun", "rdflib")
_PROBE = (
    "import sys, runpy\n"
    "sys.argv = ['skimesh', *sys.argv[1:]]\n"
    "try:\n"
    "    runpy.run_module('skimesh', run_name='__main__')\n"
    "except SystemExit:\n"
    "    pass\n"
    f"print('HEAVY', [m for m in {HEAVY!r} if m in sys.modules], file=sys.stderr)\n"
)


def _env() -> dict[str, str]:
    path = os.environ.get("PYTHONPATH", "")
    return {**os.environ, "PYTHONPATH": f"{ROOT}{os.pathsep}{path}" if path else str(ROOT)}


def _once(args: Sequence[str], code: int = 0) -> float:
    started = time.perf_counter()
    done = subprocess.run(
        [sys.executable, *args], cwd=ROOT, env=_env(), capture_output=True, timeout=60
    )
    took = time.perf_counter() - started
    if done.returncode != code:
        raise RuntimeError(f"{args}: exit {done.returncode}, not {code}\n{done.stderr!r}")
    return took


def heavy_imports(args: Sequence[str]) -> list[str]:
    """The heavy packages a ``skimesh`` command imports (its arguments after ``-m skimesh``)."""
    done = subprocess.run(
        [sys.executable, "-c", _PROBE, *args[2:]],
        cwd=ROOT,
        env=_env(),
        capture_output=True,
        text=True,
        timeout=60,
    )
    line = next(li for li in done.stderr.splitlines() if li.startswith("HEAVY "))
    return list(msgspec.json.decode(line[6:].replace("'", '"')))


def measure(
    runs: int, connected: Mapping[str, tuple[Sequence[str], int]] | None = None
) -> dict[str, Stats]:
    """Wall seconds of each command over ``runs`` rounds, the commands in turn in each round;
    with ``connected`` (arguments with their connection flags, and exit codes), those too."""
    commands = {name: (args, 0) for name, args in COMMANDS.items()}
    commands.update(connected or {})
    for args, code in commands.values():  # warm the file cache and the bytecode once
        _once(args, code)
    samples: dict[str, list[float]] = {name: [] for name in commands}
    for _ in range(runs):
        for name, (args, code) in commands.items():
            samples[name].append(_once(args, code))
    return {name: summarize(values) for name, values in samples.items()}


def make_rows(stats: Mapping[str, Stats], heavy: Mapping[str, list[str]]) -> list[Row]:
    base = stats[BASELINE]
    rows = [Row(figure=BASELINE, value=base.p50 * 1e3, unit="ms", note=f"max {base.max * 1e3:.0f}")]
    for name, s in stats.items():
        if name == BASELINE:
            continue
        loaded = ", ".join(heavy[name]) or "none"
        rows.append(
            Row(
                figure=name,
                value=s.p50 * 1e3,
                unit="ms",
                baseline=BASELINE,
                baseline_value=base.p50 * 1e3,
                target=f"< {TARGET_S * 1e3:.0f} ms",
                met=s.max < TARGET_S,
                note=f"max {s.max * 1e3:.0f}; heavy imports: {loaded}",
            )
        )
    return rows


def main(argv: Sequence[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=DESCRIPTION)
    parser.add_argument("--quick", action="store_true", help="5 runs of each command (< 15 s)")
    parser.add_argument("--runs", type=int, default=15, help="runs of each command (default 15)")
    parser.add_argument("--json", type=Path, metavar="FILE", help="also write results as JSON")
    parser.add_argument(
        "--offline", action="store_true", help="leave out the commands that ask a live mesh"
    )
    args = parser.parse_args(argv)
    runs = 5 if args.quick else args.runs
    info = machine_info(("msgspec", "eclipse-zenoh"))
    load_start = load_average()
    started = time.perf_counter()
    with contextlib.ExitStack() as stack:
        connected: dict[str, tuple[Sequence[str], int]] = {}
        if not args.offline:
            flags = stack.enter_context(loopback_site(free_port(), f"cli-{os.getpid()}"))
            connected = {name: ([*a, *flags], code) for name, (a, code) in CONNECTED.items()}
        stats = measure(runs, connected)
        every = {
            **{n: list(a) for n, a in COMMANDS.items()},
            **{n: a for n, (a, _) in connected.items()},
        }
        heavy = {name: heavy_imports(cmd) for name, cmd in every.items() if name != BASELINE}
    rows = make_rows(stats, heavy)
    print("machine: " + ", ".join(f"{k} {v}" for k, v in info.items()))
    print(
        f"run: {runs} runs of each, {time.perf_counter() - started:.0f} s; load average "
        f"{load_start} at start, {load_average()} at end\n"
    )
    print(format_table(rows))
    if args.json is not None:
        doc = {"machine": info, "runs": runs, "rows": rows, "stats": stats}
        args.json.write_bytes(msgspec.json.format(msgspec.json.encode(doc)))
    return 0 if all(r.met is not False for r in rows) else 1
