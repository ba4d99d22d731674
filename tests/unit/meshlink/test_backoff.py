"""``Backoff``: pauses that double up to a bound; saying "still waiting" at once, then once
per period."""

from __future__ import annotations

import pytest

from meshlink import Backoff

pytestmark = pytest.mark.anyio


async def test_pauses_double_up_to_the_bound_and_it_says_once_per_period() -> None:
    backoff = Backoff(0.05, 0.2, every=0.25)
    before = backoff.said
    assert backoff.due()  # at once
    assert (before, backoff.said) == (False, True)
    assert not backoff.due()  # said just now
    pauses = []
    for _ in range(4):
        pauses.append(backoff.pause)
        await backoff.wait()
    assert pauses == [0.05, 0.1, 0.2, 0.2] and backoff.pause == 0.2
    assert backoff.waited >= 0.55 - 0.01
    assert backoff.due() and not backoff.due()  # 0.25 s passed since it said
