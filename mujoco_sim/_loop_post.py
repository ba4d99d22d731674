"""Posting calls from the simulation thread to an asyncio loop without giving up the GIL.

``loop.call_soon_threadsafe`` wakes the loop by writing to its self-pipe with
``socket.send``, which releases the GIL for the system call. When the loop (or a Zenoh
callback thread) is waiting for the GIL at that moment, it takes it, and the simulation
thread waits until that thread lets go again: measured on the meal scenario with its devices
served over Zenoh (see docs/benchmarks.md, section Simulation), its Python work and
the loop's done one after the other. :class:`LoopPost` queues the call in a deque and wakes the
loop through a pipe of its own, written with ``write(2)`` called through :class:`ctypes.PyDLL`
(which keeps the GIL): the loop then gets the GIL when the simulation thread next lets it go,
in ``mj_step`` at the latest, and its work overlaps the physics. One wake-up serves all the
calls posted until the loop takes them (in order).

Only for selector-based asyncio loops (``add_reader``); :func:`loop_post` returns None
elsewhere (the caller keeps ``call_soon_threadsafe``).
"""

from __future__ import annotations

import asyncio
import contextlib
import ctypes
import functools
import os
from collections import deque
from collections.abc import Callable
from typing import Any

__all__ = ["LoopPost", "loop_post"]


@functools.cache
def _write() -> Any:
    """libc's ``write`` called with the GIL held (ctypes.PyDLL), built once (it is immutable)."""
    write = ctypes.PyDLL(None).write
    write.argtypes = (ctypes.c_int, ctypes.c_char_p, ctypes.c_size_t)
    write.restype = ctypes.c_ssize_t
    return write


class LoopPost:
    """Calls posted from one other thread, run on ``loop`` in the order posted (see module
    doc). Build and :meth:`close` on the loop; :meth:`post` from the other thread."""

    def __init__(self, loop: asyncio.AbstractEventLoop) -> None:
        self._loop = loop
        self._calls: deque[tuple[Callable[..., object], tuple[Any, ...]]] = deque()
        self._pending = False  # a wake-up is on its way: the loop will take every call
        self._read, self._wake = os.pipe()
        os.set_blocking(self._read, False)
        os.set_blocking(self._wake, False)
        self._write = _write()
        try:
            loop.add_reader(self._read, self._run)
        except BaseException:
            self._close_pipe()
            raise

    def post(self, fn: Callable[..., object], *args: Any) -> None:
        """Other thread: run ``fn(*args)`` on the loop soon; never releases the GIL."""
        self._calls.append((fn, args))
        if not self._pending:
            self._pending = True
            self._write(self._wake, b"\0", 1)

    def run_pending(self) -> None:
        """Loop: run the calls posted so far now (e.g. once the other thread is done, before
        anything that must come after them: a wake-up through the pipe is not ordered with
        ``call_soon_threadsafe`` calls)."""
        self._pending = False  # before taking the calls: a later post wakes the loop again
        calls = self._calls
        while calls:
            fn, args = calls.popleft()
            fn(*args)

    def _run(self) -> None:
        with contextlib.suppress(BlockingIOError):
            os.read(self._read, 4096)
        self.run_pending()

    def close(self) -> None:
        """Loop: stop listening; calls still queued are dropped."""
        self._loop.remove_reader(self._read)
        self._close_pipe()

    def _close_pipe(self) -> None:
        for fd in (self._read, self._wake):
            with contextlib.suppress(OSError):
                os.close(fd)


def loop_post(loop: asyncio.AbstractEventLoop) -> LoopPost | None:
    """A :class:`LoopPost` for ``loop``, or None if it cannot watch a pipe (not a selector
    loop: e.g. the proactor loop on Windows) or ``write`` is not at hand."""
    try:
        return LoopPost(loop)
    except (NotImplementedError, AttributeError, OSError):
        return None
