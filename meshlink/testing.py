"""Helpers for tests of any skimesh package (no pytest import; ``tests/conftest.py`` wraps
them in fixtures): a free loopback port, an in-process Zenoh router, a watchdog that measures
how long the event loop was blocked, raw Zenoh calls for benchmarks (:func:`call0`,
:func:`undeclare`), and fuzzing of RPC queryables (:func:`hostile_payloads`,
:func:`payloads`, :func:`check_reply`, :func:`fuzz_queryable`; hypothesis is imported only by
:func:`payloads`).
"""

from __future__ import annotations

import os
import socket
import time
from collections.abc import AsyncIterator, Iterable, Iterator, Sequence
from contextlib import asynccontextmanager, contextmanager
from typing import TYPE_CHECKING, Any

import anyio
import msgspec
import zenoh

from ._bridge import call0, undeclare
from ._config import MeshConfig, to_zenoh_config
from ._messages import Answer, IncomingQuery
from ._router import router_config
from ._session import Mesh, open_mesh
from .rpc import DEFAULT_MAX_REQUEST_BYTES, Decoder, ErrorReply, WireError

if TYPE_CHECKING:
    from hypothesis.strategies import SearchStrategy

__all__ = [
    "LoopWatch",
    "call0",
    "check_reply",
    "free_port",
    "fuzz_queryable",
    "hostile_payloads",
    "payloads",
    "remote_peer_main",
    "running_router",
    "undeclare",
    "watch_loop",
]


def free_port() -> int:
    """A TCP port on 127.0.0.1 that was free a moment ago (another process may still take
    it: :func:`running_router` retries)."""
    with socket.socket(socket.AF_INET, socket.SOCK_STREAM) as s:
        s.bind(("127.0.0.1", 0))
        port: int = s.getsockname()[1]
        return port


@contextmanager
def running_router(*, attempts: int = 5, config_file: str | None = None) -> Iterator[str]:
    """Run a Zenoh router in this process on ``tcp/127.0.0.1:<free port>`` (multicast
    scouting off) and yield its endpoint; the router session is closed on exit.
    ``config_file``: a Zenoh JSON5 file loaded first (see :class:`meshlink.MeshConfig`).
    Synchronous: opening a router is quick and does not need an event loop.

    Raises:
        zenoh.ZError: no free port could be bound in ``attempts`` tries.
    """
    for attempt in range(attempts):
        endpoint = f"tcp/127.0.0.1:{free_port()}"
        try:
            session = zenoh.open(
                to_zenoh_config(router_config([endpoint], config_file=config_file))
            )
        except zenoh.ZError:
            if attempt == attempts - 1:
                raise
            continue
        try:
            yield endpoint
        finally:
            call0(session.close)
        return


class LoopWatch:
    """Result of :func:`watch_loop`: ``max_gap`` is the longest time (seconds) the loop came
    back late to the heartbeat task, ``ticks`` how many heartbeats ran."""

    def __init__(self, interval: float) -> None:
        self.interval = interval
        self.max_gap = 0.0
        self.ticks = 0


@asynccontextmanager
async def watch_loop(interval: float = 0.005) -> AsyncIterator[LoopWatch]:
    """Run a heartbeat task that sleeps ``interval`` seconds in a loop and records how late
    each wake-up was: a blocked event loop shows up as a large ``max_gap``."""
    watch = LoopWatch(interval)

    async def heartbeat() -> None:
        last = time.perf_counter()
        while True:
            await anyio.sleep(interval)
            now = time.perf_counter()
            watch.max_gap = max(watch.max_gap, now - last - interval)
            watch.ticks += 1
            last = now

    async with anyio.create_task_group() as tg:
        tg.start_soon(heartbeat)
        try:
            yield watch
        finally:
            tg.cancel_scope.cancel()


def remote_peer_main(config: MeshConfig, token_key: str, serve_key: str) -> None:
    """Entry point of a child process (``multiprocessing`` *spawn* context: a forked child of
    a process with an open session breaks silently). Joins the mesh, serves ``serve_key``
    with ``b"<pid>|" + payload``, then declares ``token_key`` so a liveliness watcher knows it
    is ready; runs until killed."""

    async def echo(query: IncomingQuery) -> list[Answer]:
        return [Answer(serve_key, b"%d|%s" % (os.getpid(), query.payload or b""))]

    async def main() -> None:
        async with open_mesh(config) as mesh, anyio.create_task_group() as tg:
            await tg.start(mesh.serve, serve_key, echo)
            with mesh.declare_token(token_key):
                await anyio.sleep_forever()

    anyio.run(main)


# ---------------------------------------------------------------- fuzzing RPC queryables

_MARK = "zzzz-meshlink-fuzz-mark-zzzz"  # 28 characters: one fixstr header byte (0xbc)
_MARK_BYTES = msgspec.msgpack.encode(_MARK)
_DEEP = b"\x81\xa1a" * 1000 + b"\xc0"  # a map nested 1,000 deep
_DEEP_ARRAY = b"\x91" * 1000 + b"\xc0"
_BAD_UTF8 = _MARK_BYTES[:1] + b"\xff\xfe\xc3\x28" + b"a" * (len(_MARK) - 4)  # same length


def _splice(template: Any, replacement: bytes) -> bytes:
    """``template`` (holding the string :data:`_MARK` somewhere) encoded, with the encoded
    mark replaced by raw ``replacement`` bytes (which msgspec could not encode itself)."""
    return msgspec.msgpack.encode(template).replace(_MARK_BYTES, replacement)


def _mutations(sample: bytes) -> list[bytes]:
    """Hostile variants of one valid request: each string and each value replaced in turn by
    invalid UTF-8 or 1,000-deep nesting, the tag made unknown, the bytes truncated."""
    out = [sample[:-1], sample + b"\xc0", sample[: len(sample) // 2]]
    try:
        message = msgspec.msgpack.decode(sample)
    except (msgspec.MsgspecError, UnicodeDecodeError, RecursionError):
        return out
    if isinstance(message, dict):
        for key in list(message):
            for value in (_MARK, {_MARK: 1}, [_MARK]):
                changed = {**message, key: value}
                out += [_splice(changed, _BAD_UTF8), _splice(changed, _DEEP)]
            out.append(
                _splice({**{k: v for k, v in message.items() if k != key}, _MARK: 1}, _BAD_UTF8)
            )
            if isinstance(message[key], str):
                out.append(msgspec.msgpack.encode({**message, key: "NoSuchTag"}))
            out.append(msgspec.msgpack.encode({k: v for k, v in message.items() if k != key}))
    return out


def hostile_payloads(
    samples: Iterable[bytes] = (), *, huge: int = DEFAULT_MAX_REQUEST_BYTES + 1
) -> list[bytes]:
    """Fixed hostile request payloads: empty, undecodable bytes, invalid UTF-8 strings (as a
    value, a key, a tag), maps and arrays nested 1,000 deep, unknown tags, a payload of
    ``huge`` bytes (default: one byte over the default limit; 0 leaves it out), plus the
    mutations of each valid ``samples`` request (see :func:`_mutations`)."""
    out = [
        b"",
        b"\xc1",  # a byte MessagePack never uses
        b"\xff" * 16,
        b"\x81",  # a map with its entry missing
        b"\xdf\xff\xff\xff\xff",  # a map announcing 4 billion entries
        _DEEP,
        _DEEP_ARRAY,
        _splice(_MARK, _BAD_UTF8),
        _splice({"request": _MARK}, _BAD_UTF8),
        _splice({"reply": _MARK}, _BAD_UTF8),
        _splice({_MARK: 1}, _BAD_UTF8),
        _splice({"request": "Info", "x": _MARK}, _DEEP),
        msgspec.msgpack.encode({"request": "NoSuchRequest"}),
        msgspec.msgpack.encode({"cmd": "no_such_command"}),
        msgspec.msgpack.encode([1, 2, 3]),
        msgspec.msgpack.encode(None),
    ]
    if huge:
        out.append(b"\x00" * huge)
        out.append(msgspec.msgpack.encode({"request": "x" * huge}))
    for sample in samples:
        out += _mutations(sample)
    return out


def payloads(samples: Sequence[bytes] = ()) -> SearchStrategy[bytes]:
    """A hypothesis strategy of request payloads: the :func:`hostile_payloads` (without the
    huge ones: send those once, not per example), random bytes, random MessagePack values,
    and the valid ``samples`` themselves."""
    from hypothesis import strategies as st

    scalars = (
        st.none()
        | st.booleans()
        | st.integers(-(2**63), 2**64 - 1)
        | st.floats()
        | st.text()
        | st.binary()
    )
    values = st.recursive(
        scalars,
        lambda inner: st.lists(inner, max_size=4) | st.dictionaries(st.text(), inner, max_size=4),
        max_leaves=16,
    )
    fixed = hostile_payloads(samples, huge=0) + list(samples)
    return st.sampled_from(fixed) | st.binary(max_size=256) | values.map(msgspec.msgpack.encode)


def check_reply(payload: bytes, ok: bool, replies: Decoder[Any]) -> object:
    """Assert that one reply is an :class:`~meshlink.rpc.ErrorReply` (``ok`` False) or a
    valid non-error reply of the service (``ok`` True, decoded with ``replies``, a
    :class:`~meshlink.rpc.Decoder` of the service's reply union); return it decoded.

    Raises:
        AssertionError: the reply is plain text, undecodable, or its kind disagrees with ``ok``.
    """
    if not ok:
        try:
            return Decoder[ErrorReply](ErrorReply).decode(payload)
        except WireError as exc:
            raise AssertionError(
                f"error reply is no ErrorReply: {payload[:200]!r} ({exc})"
            ) from None
    try:
        reply = replies.decode(payload)
    except WireError as exc:
        raise AssertionError(f"reply does not decode: {payload[:200]!r} ({exc})") from None
    if isinstance(reply, ErrorReply):
        raise AssertionError(f"an ErrorReply sent as an ok reply: {reply!r}")
    return reply


async def fuzz_queryable(
    mesh: Mesh,
    key: str,
    replies: Decoder[Any],
    requests: Iterable[bytes],
    *,
    timeout: float = 10.0,
) -> int:
    """Send every payload of ``requests`` to ``key`` (a :meth:`Mesh.get`, so several servers
    are all checked) and :func:`check_reply` every reply; return the number of replies.

    Raises:
        AssertionError: a reply is no ErrorReply nor a valid reply, or nobody replied.
    """
    count = 0
    for payload in requests:
        answers = await mesh.get(key, payload, timeout=timeout)
        assert answers, f"no reply from {key} to {payload[:80]!r}"
        for answer in answers:
            check_reply(answer.payload, answer.ok, replies)
            count += 1
    return count
