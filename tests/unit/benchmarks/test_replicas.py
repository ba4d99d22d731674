"""The replica benchmark measures what it says: every robot's steps, one change per step, one
replica for a shared fleet and one per agent otherwise, and a replay of the run's changes."""

from __future__ import annotations

import pytest

from benchmarks.replicas import run_case

pytestmark = pytest.mark.anyio


@pytest.mark.parametrize(("replicas", "count"), [("own", 4), ("shared", 1)])
async def test_a_small_fleet_steps_and_counts_its_replicas(replicas: str, count: int) -> None:
    case, cost, _ = await run_case(3, replicas, steps=2, time_scale=0.0, cost=True)
    assert (case.steps, case.changes, case.replica_count) == (6, 6, count)
    assert case.median_ms > 0 and case.cpu_per_change_us > 0
    assert cost is not None and cost.changes == 6
    assert min(cost.decode_us, cost.replica_us, cost.listener_us) > 0
