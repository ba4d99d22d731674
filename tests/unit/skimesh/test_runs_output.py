"""``skimesh runs``: one row per run (id, skill, parameters, state, start, elapsed, outcome)."""

from __future__ import annotations

import time

from skill_agent.protocol import RunInfo, RunResult
from skimesh.commands._runs import HEAD, run_row


def test_a_row_per_run_with_its_elapsed_time_and_outcome() -> None:
    start = time.mktime((2026, 1, 2, 3, 4, 5, 0, 0, -1))
    running = RunInfo(run_id="a1", skill="pick", state="paused", params={"object": "Gear-1"},
                      started_at=start)  # fmt: skip
    assert run_row("r1", running, start + 2.5) == [
        "r1", "a1", "pick", "object=Gear-1", "paused", "03:04:05", "2.5 s", "-",
    ]  # fmt: skip
    failed = RunResult(
        run_id="b2",
        agent="r1",
        skill="place",
        seq=9,
        success=False,
        reason="execution",
        message="dropped it",
        finished_at=start + 4.0,
    )
    ended = RunInfo(run_id="b2", skill="place", state="failed", started_at=start, result=failed)
    row = run_row("r1", ended, start + 100.0)
    assert row[6:] == ["4.0 s", "execution: dropped it"] and len(row) == len(HEAD)
    ok = RunResult(run_id="c3", agent="r1", skill="noop", seq=2, success=True, reason="ok",
                   finished_at=start + 1.0)  # fmt: skip
    done = RunInfo(run_id="c3", skill="noop", state="succeeded", started_at=start, result=ok)
    assert run_row("r1", done, start + 9.0)[6:] == ["1.0 s", "ok"]
