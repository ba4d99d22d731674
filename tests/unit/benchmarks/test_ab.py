"""The A/B comparison's pure part: figures read from a benchmark's JSON, B/A per figure over
paired runs, the A/A noise and the verdict."""

from __future__ import annotations

import math
from pathlib import Path

import pytest

from benchmarks.ab import (
    QUICK_ARGS,
    Figure,
    compare,
    figures,
    format_comparisons,
    higher_is_better,
    noise_factor,
    verdict,
)
from benchmarks.ab._runner import command


def row(figure: str, value: float | None, unit: str = "µs", **extra: object) -> dict[str, object]:
    return {"figure": figure, "value": value, "unit": unit, **extra}


def test_figures_of_a_results_table() -> None:
    doc = {
        "rows": [
            row("rtt p50", 400.0, baseline="raw", baseline_value=200.0),
            row("graph build", 1500.0, "ms"),
            row("overhead", 30.0, "ms", baseline_value=20.0, paired_ratio=1.4),
            row("skipped", None, "ms", baseline_value=None),  # msgspec writes NaN as null
        ]
    }
    found = figures(doc)
    assert found["rtt p50"] == Figure(400.0, "µs", 2.0)
    assert found["graph build"].value == 1500.0
    assert math.isnan(found["graph build"].same_run)
    assert found["overhead"].same_run == 1.4  # the paired ratio, not value / baseline
    assert math.isnan(found["skipped"].value) and math.isnan(found["skipped"].same_run)


def test_figures_of_the_planning_cases() -> None:
    case = {"robots": 2, "parts": 4, "goal": "two", "status": "ok", "ours_ms": 50.0}
    doc = {
        "cases": [
            {**case, "engine": "kairos", "ratio": 1.2, "makespan": 10.0, "sequential": 20.0},
            {**case, "engine": "fast-downward", "ratio": 1.1, "makespan": 9.0, "sequential": 20.0},
            {**case, "goal": "all", "engine": "kairos", "status": "timeout"},
        ],
        "executed": [
            {
                **case,
                "estimated": 10.0,
                "estimated_sequential": 20.0,
                "ratio": 0.55,
                "overhead_ms": 1.5,
            }
        ],
    }
    found = figures(doc)
    assert found["plan 2x4 two (kairos)"] == Figure(50.0, "ms", 1.2)
    assert found["makespan 2x4 two"] == Figure(10.0, "s", 0.5)
    assert "makespan 2x4 two (fast-downward)" not in found
    assert not any("2x4 all" in name for name in found)  # timed out: no figure
    assert found["executed 2x4 two: parallel / sequential"] == Figure(0.55, "ratio", 0.5)
    assert found["executed 2x4 two: overhead per step"].value == 1.5


def test_figures_of_something_else_is_an_error() -> None:
    with pytest.raises(ValueError, match="not a benchmark"):
        figures({"machine": {}})


def test_direction_by_unit() -> None:
    assert higher_is_better("tx/s") and higher_is_better("runs/s") and higher_is_better("x")
    assert higher_is_better("of 4")
    assert not higher_is_better("µs") and not higher_is_better("ms") and not higher_is_better("%")


def test_noise_is_the_largest_factor_between_neighbours() -> None:
    assert noise_factor([100.0, 110.0, 99.0]) == pytest.approx(110 / 99)
    assert noise_factor([100.0, 50.0]) == pytest.approx(2.0)
    assert math.isnan(noise_factor([100.0]))
    assert math.isnan(noise_factor([0.0, 0.0]))


def test_verdict() -> None:
    assert verdict(1.04, math.nan, "µs") == "same"  # within 5%, always
    assert verdict(1.2, 1.3, "µs") == "same"  # within the A/A noise
    assert verdict(1.2, 1.1, "µs") == "worse"  # slower
    assert verdict(1.2, 1.1, "tx/s") == "better"  # more throughput
    assert verdict(0.8, 1.1, "tx/s") == "worse"
    assert verdict(1 / 1.2, 1.1, "µs") == "better"
    assert verdict(math.nan, 1.1, "µs") == "?"


def runs(
    name: str, values: list[float], unit: str = "µs", base: float = 100.0
) -> list[dict[str, Figure]]:
    return [{name: Figure(v, unit, v / base)} for v in values]


def test_compare_pairs_the_runs_in_order() -> None:
    a = runs("rtt", [100.0, 110.0, 100.0])
    b = runs("rtt", [130.0, 132.0, 150.0])
    (c,) = compare(a, b)
    assert c.name == "rtt" and c.unit == "µs"
    assert c.a == [100.0, 110.0, 100.0] and c.b == [130.0, 132.0, 150.0]
    assert c.ratio == pytest.approx(1.3)  # median of 1.3, 1.2, 1.5
    assert c.low == pytest.approx(1.2) and c.high == pytest.approx(1.5)
    assert c.noise == pytest.approx(150 / 132)  # B/B here, larger than A/A (1.1)
    assert c.same_run_ratio == pytest.approx(1.3)
    assert c.verdict == "worse"


def test_a_difference_within_the_noise_of_either_side_is_the_same() -> None:
    (c,) = compare(runs("rtt", [100.0, 100.0]), runs("rtt", [100.0, 150.0]))
    assert c.ratio == pytest.approx(1.25) and c.noise == pytest.approx(1.5)
    assert c.verdict == "same"


def test_compare_keeps_figures_every_paired_run_has() -> None:
    a = [{"x": Figure(1.0, "ms")}, {"x": Figure(1.0, "ms"), "y": Figure(1.0, "ms")}]
    b = [{"x": Figure(2.0, "ms"), "y": Figure(2.0, "ms")}, {"x": Figure(3.0, "ms")}]
    (c,) = compare(a, b)  # "y" is missing in a run of each side
    assert c.name == "x" and c.a == [1.0, 1.0] and c.ratio == 2.5
    assert math.isnan(c.same_run_ratio)


def test_compare_pairs_only_as_many_runs_as_the_shorter_side_has() -> None:
    a = [{"x": Figure(1.0, "ms")}, {"x": Figure(4.0, "ms")}]
    (c,) = compare(a, [{"x": Figure(2.0, "ms")}])
    assert c.a == [1.0] and c.ratio == 2.0
    assert compare([], a) == []


def test_compare_skips_zero_and_nan_pairs() -> None:
    a = runs("f", [0.0, 100.0, math.nan])
    b = runs("f", [5.0, 90.0, 80.0])
    (c,) = compare(a, b)
    assert c.ratio == pytest.approx(0.9) and c.low == c.high


def test_format_comparisons() -> None:
    text = format_comparisons(compare(runs("rtt", [100.0, 100.0]), runs("rtt", [100.0, 103.0])))
    header, rule, line = text.splitlines()
    assert header.startswith("figure") and set(rule) <= {"-", "+"}
    assert line.startswith("rtt") and "100 µs" in line and line.endswith("same")


def test_command_runs_the_benchmark_as_a_module_with_json() -> None:
    cmd = command("py", "sim", QUICK_ARGS["sim"], Path("/tmp/out.json"))
    assert cmd[:3] == ["py", "-m", "benchmarks.sim"]
    assert cmd[-2:] == ["--json", "/tmp/out.json"]
    assert "--quick" in cmd
    assert set(QUICK_ARGS) == {"wm", "skills", "planning", "sim"}
