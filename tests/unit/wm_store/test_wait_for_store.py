"""``wait_for_store``: a service started before the store waits for it, saying so when the
wait begins and again after ``every`` seconds, and returns once the store answers."""

from __future__ import annotations

from collections.abc import AsyncIterator
from contextlib import AbstractAsyncContextManager

import pytest

from wm_store import TransportError, wait_for_store
from wm_store.protocol import Change, ElementsReply, GetElements, Reply, Request


class LateStore:
    """Answers from the ``answers_from``-th request on; unreachable before."""

    def __init__(self, answers_from: int) -> None:
        self.answers_from = answers_from
        self.requests: list[Request] = []

    async def request(self, request: Request, *, timeout: float) -> Reply:
        self.requests.append(request)
        if len(self.requests) < self.answers_from:
            raise TransportError("the world-model store did not answer")
        return ElementsReply(revision=1, elements=[])

    def changes(self) -> AbstractAsyncContextManager[AsyncIterator[Change]]:
        raise NotImplementedError


@pytest.mark.anyio
async def test_waits_until_the_store_answers_and_says_so() -> None:
    store = LateStore(answers_from=4)
    said: list[float] = []
    waited = await wait_for_store(store, say=lambda w, e: said.append(w), every=0.5)
    assert len(store.requests) == 4 and all(isinstance(r, GetElements) for r in store.requests)
    assert said[0] == pytest.approx(0.0, abs=0.05)  # at once, then every 0.5 s
    assert 1 <= len(said) <= 2 and waited >= 0.2 + 0.4 + 0.8 - 0.05


@pytest.mark.anyio
async def test_a_store_that_answers_costs_one_request_and_no_message() -> None:
    store = LateStore(answers_from=1)
    said: list[float] = []
    assert await wait_for_store(store, say=lambda w, e: said.append(w)) < 1.0
    assert len(store.requests) == 1 and said == []
