"""Fixtures shared by every test of the project.

Zenoh tests (``@pytest.mark.zenoh``) run against a router in this process on a free loopback
port, with multicast scouting off; each test gets its own mesh name (``test-<uuid>``), so tests
sharing a router never see each other's keys. Sessions are always closed (an open session with
callback threads would hang interpreter exit).
"""

from __future__ import annotations

import asyncio
import gc
import time
import uuid
from collections.abc import Iterator
from typing import Protocol

# hypothesis is imported up front: pytest rewrites the asserts of modules it imports,
# hypothesis's included, and when hypothesis is first imported while pytest formats a failure
# deep in an exception group, CPython 3.11.7's ast.parse fails with "SystemError: AST
# constructor recursion depth mismatch", which hides the real failure.
import hypothesis  # noqa: F401
import pytest

from meshlink import MeshConfig, Mode
from meshlink.testing import free_port, running_router


@pytest.fixture(scope="module")
def anyio_backend() -> str:
    """Async tests (``@pytest.mark.anyio``) run on asyncio."""
    return "asyncio"


@pytest.fixture
def free_tcp_port() -> int:
    """A TCP port on 127.0.0.1 that was free a moment ago."""
    return free_port()


@pytest.fixture
def router_endpoint() -> Iterator[str]:
    """A fresh Zenoh router in this process for one test; yields ``tcp/127.0.0.1:<port>``."""
    with running_router() as endpoint:
        yield endpoint


@pytest.fixture(scope="module")
def module_router() -> Iterator[str]:
    """One Zenoh router shared by the tests of a module (use with distinct mesh names)."""
    with running_router() as endpoint:
        yield endpoint


class MeshConfigFactory(Protocol):
    """Type of the ``mesh_config`` fixture."""

    def __call__(
        self, endpoint: str, mode: Mode = "client", mesh: str | None = None
    ) -> MeshConfig: ...


@pytest.fixture
def mesh_config() -> MeshConfigFactory:
    """Factory ``(endpoint, mode="client", mesh=None) -> MeshConfig`` connecting to
    ``endpoint``; ``mesh`` defaults to one ``test-<uuid>`` name per test, shared by every
    config the test builds."""
    test_mesh = f"test-{uuid.uuid4().hex[:12]}"

    def make(endpoint: str, mode: Mode = "client", mesh: str | None = None) -> MeshConfig:
        return MeshConfig(mode=mode, connect=(endpoint,), mesh=mesh or test_mesh)

    return make


class SlowSteps:
    """Loop steps (task steps and callbacks) that held the event loop's thread, in ``reports``.

    A step is reported when its thread spent at least ``cpu`` seconds of CPU in it (a
    computation or busy wait on the loop), or when it lasted ``stall`` seconds of wall time
    whatever it did (a blocking sleep or wait). A step that only waited to be scheduled
    (another process had the core, another thread had the GIL) uses no CPU of its own, so a
    busy machine does not make a free loop look blocked; the price is that a blocking *wait*
    shorter than ``stall`` goes unseen (the heartbeat of :func:`meshlink.testing.watch_loop`
    sees those, on a quiet machine)."""

    def __init__(self, cpu: float = 0.04, stall: float = 1.0) -> None:
        self.cpu, self.stall = cpu, stall
        self.reports: list[str] = []

    def observe(self, handle: asyncio.Handle, wall: float, cpu: float) -> None:
        if cpu >= self.cpu or wall >= self.stall:
            owner = getattr(getattr(handle, "_callback", None), "__self__", None)
            what = repr(owner) if isinstance(owner, asyncio.Task) else repr(handle)
            self.reports.append(f"{what} took {wall * 1000:.0f} ms ({cpu * 1000:.0f} ms CPU)")


@pytest.fixture
def blocking_detector(monkeypatch: pytest.MonkeyPatch) -> Iterator[SlowSteps]:
    """Time every loop step for the test (see :class:`SlowSteps`), so a test can
    ``assert not detector.reports``.

    The test runner's heap (every module and object the session has made so far) is collected
    and frozen for the test, as ``skimesh sim`` settles its own after start-up: otherwise a
    full collection of it, started by whichever thread allocates, holds the GIL for longer
    than the loop may be blocked, and the test would measure pytest's heap, not the code."""
    gc.collect()
    gc.freeze()
    detector = SlowSteps()
    run = asyncio.Handle._run

    def timed(handle: asyncio.Handle) -> None:
        wall, cpu = time.perf_counter(), time.thread_time()
        try:
            run(handle)
        finally:
            detector.observe(handle, time.perf_counter() - wall, time.thread_time() - cpu)

    monkeypatch.setattr(asyncio.Handle, "_run", timed)
    try:
        yield detector
    finally:
        gc.unfreeze()
