"""Fixtures shared by every test of the project.

Zenoh tests (``@pytest.mark.zenoh``) run against a router in this process on a free loopback
port, with multicast scouting off; each test gets its own mesh name (``test-<uuid>``), so tests
sharing a router never see each other's keys. Sessions are always closed (an open session with
callback threads would hang interpreter exit).
"""

from __future__ import annotations

import asyncio
import logging
import uuid
from collections.abc import AsyncIterator, Iterator
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


class SlowSteps(logging.Handler):
    """Collects asyncio's debug-mode reports of loop steps that ran too long."""

    def __init__(self) -> None:
        super().__init__(logging.WARNING)
        self.reports: list[str] = []

    def emit(self, record: logging.LogRecord) -> None:
        message = record.getMessage()
        if message.startswith("Executing"):
            self.reports.append(message)


@pytest.fixture
async def blocking_detector() -> AsyncIterator[SlowSteps]:
    """Put the running asyncio loop in debug mode with ``slow_callback_duration = 50 ms`` for
    the test: every loop step (task step or callback) that runs longer is recorded in
    ``.reports`` with its task, so a test can ``assert not detector.reports``."""
    loop = asyncio.get_running_loop()
    debug, slow = loop.get_debug(), loop.slow_callback_duration
    detector = SlowSteps()
    logger = logging.getLogger("asyncio")
    logger.addHandler(detector)
    loop.set_debug(True)
    loop.slow_callback_duration = 0.05
    try:
        yield detector
    finally:
        loop.set_debug(debug)
        loop.slow_callback_duration = slow
        logger.removeHandler(detector)
