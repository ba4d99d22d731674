"""Running a long-lived command: logging set-up, a clean stop on SIGINT / SIGTERM, a settled heap.

Every ``skimesh`` service runs its main coroutine through :func:`run_service`, which cancels it
when the process receives SIGINT or SIGTERM, so every Zenoh session is closed and the world
model writes its final snapshot before the process exits. These are settings of the process,
made by its command (never by library code on import).
"""

from __future__ import annotations

import gc
import logging
import signal
import sys
from collections.abc import Awaitable, Callable

import anyio

__all__ = ["PublicNames", "configure_logging", "run_service", "settle_heap"]


def configure_logging(verbosity: int) -> None:
    """``-v`` for INFO, ``-vv`` for DEBUG; warnings and errors always, on stderr. Each line
    names its logger by the public concept it comes from (:class:`PublicNames`)."""
    root = logging.getLogger()
    if not root.handlers:  # as logging.basicConfig: a host that set up logging keeps its own
        root.setLevel(logging.WARNING - 10 * min(verbosity, 2))
        handler = logging.StreamHandler(sys.stderr)
        handler.setFormatter(
            PublicNames("%(asctime)s %(levelname).1s %(concept)s: %(message)s", "%H:%M:%S")
        )
        root.addHandler(handler)


class PublicNames(logging.Formatter):
    """Loggers are named by module (``logging.getLogger(__name__)``, so ``-v`` and logging
    configs can pick a package); a line names the public concept instead, cut before the first
    private module: ``skill_agent.server._serving`` shows as ``skill_agent.server``."""

    def format(self, record: logging.LogRecord) -> str:
        parts = record.name.split(".")
        private = next((i for i, part in enumerate(parts) if part.startswith("_")), len(parts))
        record.concept = ".".join(parts[: max(1, private)])
        return super().format(record)


def settle_heap() -> None:
    """Call once start-up is over (the world built, solvers loaded): collect, then move every
    object alive now out of the garbage collector's generations (``gc.freeze``).

    Why: a process that has loaded MuJoCo models, placo solvers and Zenoh sessions holds a
    large heap of start-up objects that live as long as it does, and every full collection
    scans all of them, holding the GIL in the thread that happened to trigger it (the
    simulation thread as often as not; see docs/benchmarks.md, section Simulation, "What made
    the difference", item 12). Frozen, they are never scanned again; objects made later are
    collected as usual. Nothing is leaked: the frozen objects were reachable anyway.
    """
    gc.collect()
    gc.freeze()


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
