"""SPARQL in a worker process: no query can stall the store.

The store's event loop never parses or evaluates SPARQL. :class:`SparqlWorker` hands each
query to a child process that keeps a copy of the scene and the store's ontology, where a
:class:`~wm_store.rdf.SparqlEngine` parses, checks and evaluates it. The copy follows the store
by the changes since its revision (a snapshot when the child starts, or when the store no
longer keeps those changes), so the loop pays only the encoding of what changed since the last
query and the pipe's I/O, which runs in a worker thread. The child runs at a lower CPU
priority (``nice`` 10), and the store stops it while it serves other requests
(:class:`~._slicer.Slicer`: ``SIGSTOP`` and ``SIGCONT``, bounded so a query progresses), so a
query yields the processor to the store's work.

Limits, each refused with :class:`~wm_store.QueryLimitError` (code ``query_limit``):

- **text**: a query longer than ``max_text`` bytes is refused before it leaves the loop;
- **time**: a query (with the graph build it needs) running longer than ``timeout`` seconds
  (the time it was stopped not counted) is ended by killing the child; the next query starts a
  fresh one;
- **rows**: more than ``max_rows`` rows (SELECT) or triples (CONSTRUCT) end the query;
- **queue**: one query runs at a time; more than ``max_waiting`` waiting are refused as busy.

The child is started (``spawn``: never a fork of a process with a Zenoh session) on the
first query, not before, from a thread of the worker's own that lives as long as the worker:
the child asks the kernel to kill it when that thread ends (``PR_SET_PDEATHSIG``), so it dies
with the store even after a SIGKILL and even while stopped; it also ends when its pipe closes.
A child that dies otherwise is replaced on the next query.
"""

from __future__ import annotations

import contextlib
import ctypes
import logging
import multiprocessing
import os
import signal
from collections.abc import Callable, Mapping
from concurrent.futures import ThreadPoolExecutor
from multiprocessing.connection import Connection
from multiprocessing.process import BaseProcess
from typing import Any, Final

import anyio
import msgspec

from meshlink.rpc import ErrorReply, encode
from wm_store._errors import WM_CODES, QueryLimitError, ValidationError, WmError, remote_error
from wm_store.protocol import Change, SnapshotReply, SparqlReply

from ._slicer import Slicer

__all__ = ["SparqlWorker"]

_log = logging.getLogger(__name__)
_snapshot: Final = msgspec.msgpack.Decoder(SnapshotReply)
_payloads: Final = msgspec.msgpack.Decoder(list[bytes])
_change: Final = msgspec.msgpack.Decoder(Change)

_NICE: Final = 10
"""The child's CPU priority: below the store's, yet not starved on a busy host (idle
scheduling, or ``nice`` 19, would let a saturated machine stall every query until its
time limit)."""


_PR_SET_PDEATHSIG: Final = 1


def _lower_priority(pid: int) -> None:
    """Ad-hoc queries yield the processor to the store's work (``nice`` :data:`_NICE`)."""
    with contextlib.suppress(OSError):
        os.setpriority(os.PRIO_PROCESS, pid, _NICE)


def _die_with_parent(parent: int) -> None:
    """In the child: the kernel kills it (``SIGKILL``, which ends a stopped process too) when
    the thread that started it ends, i.e. when the store's process dies (Linux); it exits at
    once if the store died before this took effect."""
    with contextlib.suppress(OSError, AttributeError):
        libc = ctypes.CDLL(None, use_errno=True)
        libc.prctl(_PR_SET_PDEATHSIG, signal.SIGKILL)
    if os.getppid() != parent:
        os._exit(0)


SyncSource = Callable[[int | None], tuple[str, bytes, int]]
"""What brings the child's copy of the scene from a revision to the store's (see
:meth:`SparqlWorker.query`)."""
_reply: Final = msgspec.msgpack.Decoder(SparqlReply)


class SparqlWorker:
    """One child process answering SPARQL for one store (see the module doc)."""

    def __init__(
        self,
        *,
        timeout: float = 10.0,
        max_text: int = 16 * 1024,
        max_rows: int = 10_000,
        max_waiting: int = 8,
        core: Callable[[], tuple[str, str]] = lambda: ("", ""),
        slicer: Slicer | None = None,
    ) -> None:
        self.core = core
        """The store's core ontology, as (digest, Turtle), asked when a child starts: the
        child replays the store's ontology log on it."""
        self.timeout, self.max_text = timeout, max_text
        self.max_rows, self.max_waiting = max_rows, max_waiting
        self._process: BaseProcess | None = None
        self._conn: Connection | None = None
        self._synced: int | None = None
        """The revision of the child's copy of the scene (None: it has none)."""
        self._lock = anyio.Lock()
        self._waiting = 0
        self.started = 0
        """How many children were started (statistics; tests see a runaway replaced)."""
        self.slicer = slicer or Slicer()
        """Stops the child while the store serves other requests (:meth:`serving`)."""
        self._parent: ThreadPoolExecutor | None = None  # the thread that starts children

    def serving(self) -> contextlib.AbstractContextManager[None]:
        """Around a request the store serves (other than SPARQL): the child running a query
        is stopped meanwhile, within the bound (see :class:`~._slicer.Slicer`)."""
        return self.slicer.serving()

    @property
    def pid(self) -> int | None:
        """The child's process id (None: no child)."""
        return self._process.pid if self._process is not None else None

    async def query(
        self, source: SyncSource, text: str, bindings: Mapping[str, str]
    ) -> SparqlReply:
        """Answer ``text`` over the scene. ``source(revision)`` gives what brings the child's
        copy from ``revision`` (None: it has none) to the store's, called on the loop:
        ``("changes", the changes as published, revision)`` or ``("scene", an encoded
        SnapshotReply, revision)``. Raises QueryLimitError or ValidationError."""
        size = len(text.encode())
        if size > self.max_text:
            raise QueryLimitError(
                f"the SPARQL text is {size} bytes, over the limit of {self.max_text}"
            )
        if self._waiting >= self.max_waiting:
            raise QueryLimitError(
                f"the SPARQL worker is busy ({self._waiting} queries waiting); try again later"
            )
        self._waiting += 1
        try:
            async with self._lock:
                return await self._run(source, text, bindings)
        finally:
            self._waiting -= 1

    async def _run(self, source: SyncSource, text: str, bindings: Mapping[str, str]) -> SparqlReply:
        conn = await self._child()
        kind, data, revision = source(self._synced)
        messages: list[tuple[Any, ...]] = []
        if kind == "scene" or data:
            messages.append((kind, data))
        messages.append(("query", text, dict(bindings), self.max_rows))
        self._synced = None  # until the child has it all
        answer = await self._exchange(conn, messages)
        if answer is None:
            await self._stop()
            raise QueryLimitError(
                f"the SPARQL query ran longer than {self.timeout} s and was stopped; "
                "narrow the pattern or add LIMIT"
            )
        if isinstance(answer, EOFError | OSError):
            await self._stop()
            raise QueryLimitError(f"the SPARQL worker ended during the query ({answer})")
        self._synced = revision
        kind, *rest = answer
        if kind == "ok":
            return _reply.decode(rest[0])
        code, message = rest
        reply = ErrorReply(code=code, message=message)
        raise WM_CODES.get(code, remote_error)(reply)

    async def _exchange(
        self, conn: Connection, messages: list[tuple[Any, ...]]
    ) -> tuple[Any, ...] | EOFError | OSError | None:
        """Send ``messages``, receive the answer: None when the time limit passed first (the
        time the slicer stopped the child added to it), the error when the child ended."""
        assert self._process is not None and self._process.pid is not None
        scope = anyio.CancelScope(deadline=anyio.current_time() + self.timeout)
        answer: tuple[Any, ...] | EOFError | OSError | None = None
        async with anyio.create_task_group() as tg:
            tg.start_soon(self.slicer.pace)
            self.slicer.attach(self._process.pid, scope)
            try:
                with scope:
                    for message in messages:
                        await anyio.to_thread.run_sync(conn.send, message)
                    answer = await anyio.to_thread.run_sync(conn.recv, abandon_on_cancel=True)
            except (EOFError, OSError) as exc:
                answer = exc
            finally:
                self.slicer.detach()
                tg.cancel_scope.cancel()
        return answer

    async def _child(self) -> Connection:
        if self._conn is not None and self._process is not None and self._process.is_alive():
            return self._conn
        await self._stop()
        context = multiprocessing.get_context("spawn")
        parent, child = context.Pipe()
        process = context.Process(
            target=_serve,
            args=(child, self.core(), os.getpid()),
            name="skimesh-sparql",
            daemon=True,
        )
        if self._parent is None:
            self._parent = ThreadPoolExecutor(1, thread_name_prefix="skimesh-sparql-parent")
        parent_thread = self._parent
        await anyio.to_thread.run_sync(lambda: parent_thread.submit(process.start).result())
        if process.pid is not None:  # lower its priority at once: its imports cost CPU too
            _lower_priority(process.pid)
        child.close()
        self._process, self._conn, self._synced = process, parent, None
        self.started += 1
        return parent

    async def _stop(self) -> None:
        self.slicer.detach()
        process, conn = self._process, self._conn
        self._process = self._conn = self._synced = None
        if conn is not None:
            conn.close()
        if process is not None and process.is_alive():
            process.kill()
            await anyio.to_thread.run_sync(process.join, 5.0)

    async def aclose(self) -> None:
        """End the child (if any) and the thread that starts children."""
        await self._stop()
        if self._parent is not None:
            self._parent.shutdown(wait=False)
            self._parent = None


def _serve(conn: Connection, core: tuple[str, str], parent: int) -> None:
    """The child: keep the scene it was sent, answer queries until the pipe closes (or the
    store's process ``parent`` dies)."""
    from wm_store.ontology import Ontology, replay
    from wm_store.protocol import ClassDefined, TemplateDefined, TermsDefined
    from wm_store.rdf._sparql import SparqlEngine
    from wm_store.scene import SceneState

    _die_with_parent(parent)
    _lower_priority(0)
    digest, text = core
    base = Ontology.default()
    if digest and digest != base.digest:
        base = Ontology.load(text)
    engine = SparqlEngine(max_rows=0)
    state, ontology = SceneState(), base
    while True:
        try:
            message = conn.recv()
        except (EOFError, OSError):
            return
        try:
            if message[0] == "scene":
                snap = _snapshot.decode(message[1])
                ontology = replay(base, snap.ontology)
                spatial = (n for n, r in ontology.relations.items() if r.spatial)
                state = SceneState.from_snapshot(snap, spatial)
                continue
            if message[0] == "changes":
                for payload in _payloads.decode(message[1]):
                    change = _change.decode(payload)
                    for delta in change.deltas:
                        state.apply(delta)
                        if isinstance(delta, ClassDefined | TemplateDefined | TermsDefined):
                            ontology = replay(ontology, [delta])
                            state.set_spatial_predicates(
                                n for n, r in ontology.relations.items() if r.spatial
                            )
                    state.revision = change.revision
                continue
            _, query, bindings, max_rows = message
            engine.max_rows = max_rows
            conn.send(("ok", encode(engine.query(state, ontology, query, bindings))))
        except WmError as exc:
            conn.send(("error", exc.code, str(exc)))
        except Exception as exc:  # rdflib and the parser raise anything
            conn.send(("error", ValidationError.code, f"{type(exc).__name__}: {exc}"))
