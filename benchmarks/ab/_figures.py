"""The A/B comparison's pure part: headline figures out of a benchmark's JSON, and the per-figure
statistics of B against A over paired runs."""

from __future__ import annotations

import itertools
import math
import statistics
from collections.abc import Mapping, Sequence
from typing import Any

import msgspec

from benchmarks.common import fmt_num, format_grid

HIGHER_IS_BETTER = ("tx/s", "runs/s", "x", "of ")
"""Units (prefixes) of figures where more is better; for every other unit (times, CPU shares)
less is better."""

NOISE_FLOOR = 0.05
"""A median B/A within 5% of 1 is never called a change, whatever the A/A spread."""


class Figure(msgspec.Struct, frozen=True):
    """One headline figure of one run; ``same_run`` is its ratio to the baseline measured in
    the same run (NaN when it has none)."""

    value: float
    unit: str
    same_run: float = math.nan


class Comparison(msgspec.Struct, frozen=True):
    """One figure over the runs: B/A per pair, and A/A and B/B (consecutive runs of one side)
    as the noise."""

    name: str
    unit: str
    a: list[float]
    b: list[float]
    ratio: float  # median of the pairs' B/A
    low: float  # smallest pair's B/A
    high: float  # largest pair's B/A
    noise: float  # largest factor between consecutive runs of one side, >= 1 (NaN: < 2 pairs)
    same_run_ratio: float  # median of the pairs' B/A of the same-run ratio (NaN: none)
    verdict: str  # "same", "better", "worse" or "?" (no figure to compare)


def higher_is_better(unit: str) -> bool:
    return unit.startswith(HIGHER_IS_BETTER)


def number(value: float | None) -> float:
    """A figure from JSON: ``null`` (how msgspec writes NaN) and absent are NaN."""
    return math.nan if value is None else float(value)


def _row_figures(rows: Sequence[Mapping[str, Any]]) -> dict[str, Figure]:
    out: dict[str, Figure] = {}
    for row in rows:
        value, base = number(row["value"]), number(row.get("baseline_value"))
        paired = row.get("paired_ratio")
        if paired is not None:
            same_run = number(paired)
        elif base and not math.isnan(base):
            same_run = value / base
        else:
            same_run = math.nan
        out[str(row["figure"])] = Figure(value, str(row["unit"]), same_run)
    return out


def _planning_figures(doc: Mapping[str, Any]) -> dict[str, Figure]:
    out: dict[str, Figure] = {}
    for c in doc.get("cases", ()):
        if c.get("status") != "ok":
            continue
        name = f"{c['robots']}x{c['parts']} {c['goal']}"
        ours, ratio = number(c.get("ours_ms")), number(c.get("ratio"))
        out[f"plan {name} ({c['engine']})"] = Figure(ours, "ms", ratio)
        if c["engine"] == "kairos":
            makespan, sequential = number(c.get("makespan")), number(c.get("sequential"))
            out[f"makespan {name}"] = Figure(makespan, "s", _ratio(makespan, sequential))
    for e in doc.get("executed", ()):
        if e.get("status") != "ok":
            continue
        name = f"{e['robots']}x{e['parts']} {e['goal']}"
        estimated = _ratio(number(e.get("estimated")), number(e.get("estimated_sequential")))
        out[f"executed {name}: overhead per step"] = Figure(number(e.get("overhead_ms")), "ms")
        out[f"executed {name}: parallel / sequential"] = Figure(
            number(e.get("ratio")), "ratio", estimated
        )
    return out


def figures(doc: Mapping[str, Any]) -> dict[str, Figure]:
    """The headline figures of a benchmark's ``--json`` document: its results table (``rows``:
    world model, skills, simulation) or its planning cases (``cases``, ``executed``)."""
    if "rows" in doc:
        return _row_figures(doc["rows"])
    if "cases" in doc:
        return _planning_figures(doc)
    raise ValueError("no 'rows' and no 'cases': not a benchmark's JSON output")


def _ratio(b: float, a: float) -> float:
    if a == 0 or math.isnan(a) or math.isnan(b):
        return math.nan
    return b / a


def noise_factor(a: Sequence[float]) -> float:
    """How far apart consecutive A runs were: the largest max(x/y, y/x) of neighbours, >= 1."""
    factors = [math.exp(abs(math.log(y / x))) for x, y in itertools.pairwise(a) if x > 0 and y > 0]
    return max(factors) if factors else math.nan


def verdict(ratio: float, noise: float, unit: str) -> str:
    """``same`` when the median B/A is within the noise (and always within 5%), else
    ``better`` or ``worse`` by the figure's direction; ``?`` when there is nothing to compare."""
    if math.isnan(ratio):
        return "?"
    bound = max(1.0 + NOISE_FLOOR, noise if not math.isnan(noise) else 1.0)
    if 1.0 / bound <= ratio <= bound:
        return "same"
    return "better" if (ratio > 1.0) == higher_is_better(unit) else "worse"


def compare(
    runs_a: Sequence[Mapping[str, Figure]], runs_b: Sequence[Mapping[str, Figure]]
) -> list[Comparison]:
    """Pair the i-th A run with the i-th B run; one :class:`Comparison` per figure present in
    every run of both sides (in the order of A's first run)."""
    pairs = min(len(runs_a), len(runs_b))
    if pairs == 0:
        return []
    runs_a, runs_b = runs_a[:pairs], runs_b[:pairs]
    out: list[Comparison] = []
    for name, first in runs_a[0].items():
        if not all(name in r for r in (*runs_a, *runs_b)):
            continue
        a = [r[name].value for r in runs_a]
        b = [r[name].value for r in runs_b]
        ratios = [x for x in map(_ratio, b, a) if not math.isnan(x)]
        same = [
            x
            for x in (
                _ratio(rb[name].same_run, ra[name].same_run)
                for ra, rb in zip(runs_a, runs_b, strict=True)
            )
            if not math.isnan(x)
        ]
        ratio = statistics.median(ratios) if ratios else math.nan
        noise = max(noise_factor(a), noise_factor(b), key=lambda x: -1.0 if math.isnan(x) else x)
        out.append(
            Comparison(
                name=name,
                unit=first.unit,
                a=a,
                b=b,
                ratio=ratio,
                low=min(ratios) if ratios else math.nan,
                high=max(ratios) if ratios else math.nan,
                noise=noise,
                same_run_ratio=statistics.median(same) if same else math.nan,
                verdict=verdict(ratio, noise, first.unit),
            )
        )
    return out


def _x(value: float) -> str:
    return "-" if math.isnan(value) else f"{value:.2f}x"


def format_comparisons(rows: Sequence[Comparison]) -> str:
    """One line per figure: A and B medians, B/A median [min-max], A/A noise, same-run B/A,
    verdict."""
    head = ("figure", "A (median)", "B (median)", "B/A [min-max]", "A/A noise", "same-run B/A", "")
    body = [
        (
            c.name,
            f"{fmt_num(statistics.median(c.a))} {c.unit}",
            f"{fmt_num(statistics.median(c.b))} {c.unit}",
            f"{_x(c.ratio)} [{_x(c.low)}-{_x(c.high)}]",
            _x(c.noise),
            _x(c.same_run_ratio),
            c.verdict,
        )
        for c in rows
    ]
    return format_grid(head, body)
