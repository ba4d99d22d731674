"""Running a long-lived command: logging set-up and a clean stop on SIGINT / SIGTERM.

Every ``skimesh`` service runs its main coroutine through :func:`run_service`, which cancels it
when the process receives SIGINT or SIGTERM, so every Zenoh session is closed and the world
model writes its final snapshot before the process exits.
"""

from __future__ import annotations

import logging
import signal
import sys
from collections.abc import Awaitable, Callable

import anyio

__all__ = ["configure_logging", "run_service"]


def configure_logging(verbosity: int) -> None:
    """``-v`` for INFO, ``-vv`` for DEBUG; warnings and errors always, on stderr."""
    level = logging.WARNING - 10 * min(verbosity, 2)
    logging.basicConfig(
        level=level,
        stream=sys.stderr,
        format="%(asctime)s %(levelname).1s %(name)s: %(message)s",
        datefmt="%H:%M:%S",
    )


def run_service(main: Callable[[], Awaitable[int]]) -> int:
    """Run ``main`` until it returns or the process is asked to stop; return its exit code."""

    async def supervised() -> int:
        code = 0
        async with anyio.create_task_group() as tg:

            async def watch_signals() -> None:
                with anyio.open_signal_receiver(signal.SIGINT, signal.SIGTERM) as signals:
                    async for signum in signals:
                        logging.getLogger("skimesh").info(
                            "%s received: stopping", signal.Signals(signum).name
                        )
                        tg.cancel_scope.cancel()
                        return

            async def body() -> None:
                nonlocal code
                code = await main()
                tg.cancel_scope.cancel()

            tg.start_soon(watch_signals)
            tg.start_soon(body)
        return code

    return anyio.run(supervised)
