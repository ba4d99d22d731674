"""The A/B comparison's runs: each benchmark in two checkouts, interleaved, one subprocess per
run, then the comparison tables."""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import tempfile
import time
from collections.abc import Sequence
from pathlib import Path

import msgspec

from benchmarks.ab._figures import Comparison, Figure, compare, figures, format_comparisons
from benchmarks.common import load_average

QUICK_ARGS: dict[str, tuple[str, ...]] = {
    "skills": ("--quick",),
    "wm": ("--quick",),
    "planning": ("--quick",),
    "sim": ("--quick", "--scenario", "meal"),
}
"""The cheapest meaningful invocation of each benchmark (``python -m benchmarks.<name> ...``);
``--json FILE`` is appended."""

DESCRIPTION = "A/B: the same benchmark runs in two checkouts, interleaved; B/A per figure."


def command(python: str, bench: str, args: Sequence[str], json_path: Path) -> list[str]:
    return [python, "-m", f"benchmarks.{bench}", *args, "--json", str(json_path)]


def run_once(
    python: str, checkout: Path, bench: str, args: Sequence[str], log: Path, timeout: float
) -> dict[str, Figure] | None:
    """One run in ``checkout`` (its cwd and its PYTHONPATH); its figures, or None if it wrote no
    JSON (its output is in ``log`` either way). A nonzero exit with JSON (a missed target)
    counts."""
    with tempfile.TemporaryDirectory(prefix="skimesh-ab-") as tmp:
        out = Path(tmp) / "result.json"
        env = {**os.environ, "PYTHONPATH": str(checkout)}
        with log.open("w") as sink:
            try:
                done = subprocess.run(
                    command(python, bench, args, out),
                    cwd=checkout,
                    env=env,
                    stdin=subprocess.DEVNULL,
                    stdout=sink,
                    stderr=subprocess.STDOUT,
                    timeout=timeout,
                    check=False,
                )
                code: int | str = done.returncode
            except subprocess.TimeoutExpired:
                code = "timeout"
        if not out.exists():
            print(f"  no JSON (exit {code}); see {log}", file=sys.stderr, flush=True)
            return None
        return figures(json.loads(out.read_bytes()))


def run_ab(
    benches: Sequence[str],
    checkouts: dict[str, Path],
    runs: int,
    *,
    python: str,
    logs: Path,
    timeout: float,
    extra: dict[str, tuple[str, ...]],
) -> dict[str, list[Comparison]]:
    """Per benchmark, ``runs`` pairs A,B,A,B... (the order within a pair alternates, ABBA, so
    that a drift of the machine's load does not favour one side)."""
    results: dict[str, list[Comparison]] = {}
    for bench in benches:
        found: dict[str, list[dict[str, Figure]]] = {"a": [], "b": []}
        for i in range(runs):
            for side in ("a", "b") if i % 2 == 0 else ("b", "a"):
                started = time.perf_counter()
                print(
                    f"{bench} {side.upper()} run {i + 1}/{runs} (load {load_average()})...",
                    file=sys.stderr,
                    flush=True,
                )
                log = logs / f"{bench}-{side}-{i + 1}.log"
                args = extra.get(bench, QUICK_ARGS[bench])
                got = run_once(python, checkouts[side], bench, args, log, timeout)
                if got is not None:
                    found[side].append(got)
                took = time.perf_counter() - started
                print(f"  {took:.0f} s", file=sys.stderr, flush=True)
        results[bench] = compare(found["a"], found["b"])
    return results


def main(argv: Sequence[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=DESCRIPTION)
    parser.add_argument("--a", type=Path, required=True, help="checkout A (e.g. the old commit)")
    parser.add_argument("--b", type=Path, default=Path("."), help="checkout B (default: .)")
    parser.add_argument(
        "--bench",
        action="append",
        choices=sorted(QUICK_ARGS),
        help="benchmarks to compare (repeatable; default: all, in the order skills, wm, "
        "planning, sim)",
    )
    parser.add_argument("--runs", type=int, default=5, help="pairs per benchmark (default 5)")
    parser.add_argument(
        "--args",
        action="append",
        default=[],
        metavar="BENCH=ARGS",
        help="replace a benchmark's arguments, e.g. --args 'sim=--quick --scenario kitting'",
    )
    parser.add_argument("--python", default=sys.executable, help="interpreter for both sides")
    parser.add_argument("--timeout", type=float, default=900.0, help="seconds per run")
    parser.add_argument("--logs", type=Path, help="keep every run's output here")
    parser.add_argument("--json", type=Path, metavar="FILE", help="also write the comparisons")
    args = parser.parse_args(argv)
    checkouts = {"a": args.a.resolve(), "b": args.b.resolve()}
    for side, path in checkouts.items():
        if not (path / "benchmarks").is_dir():
            parser.error(f"--{side} {path}: no benchmarks/ there")
    extra = {}
    for item in args.args:
        bench, _, rest = item.partition("=")
        extra[bench] = tuple(rest.split())
    benches = args.bench or list(QUICK_ARGS)
    started = time.perf_counter()
    with tempfile.TemporaryDirectory(prefix="skimesh-ab-logs-") as tmp:
        logs = args.logs or Path(tmp)
        logs.mkdir(parents=True, exist_ok=True)
        results = run_ab(
            benches,
            checkouts,
            max(1, args.runs),
            python=args.python,
            logs=logs,
            timeout=args.timeout,
            extra=extra,
        )
    print(f"A: {checkouts['a']}\nB: {checkouts['b']}")
    print(f"{args.runs} pair(s) per benchmark, {time.perf_counter() - started:.0f} s in all")
    for bench, rows in results.items():
        print(f"\n{bench} ({' '.join(extra.get(bench, QUICK_ARGS[bench]))})")
        print(format_comparisons(rows) if rows else "no complete pair")
    if args.json is not None:
        doc = {"a": str(checkouts["a"]), "b": str(checkouts["b"]), "results": results}
        args.json.write_bytes(msgspec.json.format(msgspec.json.encode(doc)))
    return 0 if all(results.values()) else 1
