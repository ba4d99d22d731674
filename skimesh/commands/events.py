"""``skimesh eventlog`` keeps the site event log; ``skimesh events`` reads it from any host.

``skimesh eventlog --data FILE`` follows the whole mesh into one SQLite file (see
:mod:`skimesh.eventlog`); ``skimesh events`` filters it by time, robot, task, skill, kind,
outcome and text, follows it (``--follow``), and exports JSON lines or Parquet
(``--export FILE``).
"""

from __future__ import annotations

import argparse
import functools
import logging
import os
import re
import sys
import time
from datetime import datetime
from typing import TYPE_CHECKING

import anyio

from meshlink import add_mesh_arguments

from ..runtime import run_service
from ._connect import mesh_session, service_mesh, store_answers

if TYPE_CHECKING:
    from collections.abc import AsyncIterator

    from ..eventlog import EventFilter, EventRecord, LogInfoReply

__all__ = ["add_parser", "parse_time"]

_log = logging.getLogger("skimesh.eventlog")
_AGO = re.compile(r"^(\d+(?:\.\d+)?)\s*(s|m|h|d)$")
_UNIT = {"s": 1.0, "m": 60.0, "h": 3600.0, "d": 86400.0}
_KINDS = ("task", "run", "agent", "wm", "device")


def parse_time(text: str, *, now: float | None = None) -> float:
    """Seconds since the epoch from ``10m`` / ``2h`` / ``1d`` / ``30s`` ago, an ISO time
    (``2026-11-28T08:00``, local time unless it names a zone) or a number of seconds since the
    epoch. Raises ``argparse.ArgumentTypeError`` for anything else."""
    text = text.strip()
    ago = _AGO.match(text)
    if ago:
        return (time.time() if now is None else now) - float(ago[1]) * _UNIT[ago[2]]
    try:
        return float(text)
    except ValueError:
        pass
    try:
        return datetime.fromisoformat(text).timestamp()
    except ValueError:
        raise argparse.ArgumentTypeError(
            f"{text!r} is no time: give e.g. 10m, 2h, 1d (ago), 2026-11-28T08:00 or epoch seconds"
        ) from None


def add_parser(sub: argparse._SubParsersAction[argparse.ArgumentParser]) -> None:
    serve = sub.add_parser(
        "eventlog",
        help="keep the site event log (every task, run, agent, device and world-model event)",
        description="Follow the whole mesh into one durable SQLite file and answer "
        "`skimesh events` from any host. World-model changes missed while it was down are "
        "fetched from the store at start.",
    )
    serve.add_argument(
        "--data", metavar="FILE", default="skimesh-events.sqlite", help="the log's SQLite file"
    )
    serve.add_argument(
        "--no-wm", action="store_true", help="do not follow the world model (no store on the mesh)"
    )
    serve.add_argument("--timeout", type=float, default=10.0, help="world-model timeout (s)")
    add_mesh_arguments(serve)
    serve.set_defaults(func=_serve)

    query = sub.add_parser(
        "events",
        help="filter, follow and export the site event log (`skimesh eventlog` keeps it)",
        description="Print the records of the site event log that match every filter given, "
        "oldest first. Times: 10m, 2h, 1d (ago), an ISO time or epoch seconds. Exit codes: "
        "0 ok (also when nothing matches), 2 bad input, 3 no event log answered.",
    )
    query.add_argument("--since", type=parse_time, help="records at or after this time")
    query.add_argument("--until", type=parse_time, help="records before this time")
    query.add_argument("--robot", default="", help="only this agent or robot")
    query.add_argument("--task", default="", help="only this task")
    query.add_argument("--skill", default="", help="only this skill")
    query.add_argument("--outcome", default="", help="only this outcome (succeeded, failed, ...)")
    query.add_argument(
        "--kind", action="append", choices=_KINDS, help="only this kind (repeatable)"
    )
    query.add_argument("--grep", default="", help="only records whose text contains this")
    query.add_argument("--follow", "-f", action="store_true", help="then follow new records")
    query.add_argument("--json", action="store_true", help="one JSON object per line")
    query.add_argument(
        "--export",
        metavar="FILE",
        help="write the records to FILE (.parquet: Parquet; else JSON lines) instead of printing",
    )
    query.add_argument("--info", action="store_true", help="what the log holds, then exit")
    query.add_argument("--timeout", type=float, default=5.0, help="request timeout (s)")
    add_mesh_arguments(query)
    query.set_defaults(func=_events)


def _serve(args: argparse.Namespace) -> int:
    from ..eventlog import serve_event_log

    async def main() -> int:
        async with service_mesh(args, "event log") as mesh, anyio.create_task_group() as tg:
            if not args.no_wm:
                await store_answers(mesh, "event log", timeout=args.timeout)
            serve = functools.partial(
                serve_event_log,
                mesh,
                args.data,
                world_model=not args.no_wm,
                wm_timeout=args.timeout,
            )
            await tg.start(serve)
            _log.info("event log ready on mesh %r: %s", mesh.keys.mesh, args.data)
        return 0

    return run_service(main)


def _filter(args: argparse.Namespace) -> EventFilter:
    from ..eventlog import EventFilter

    return EventFilter(
        since=args.since,
        until=args.until,
        kinds=list(args.kind or []),
        robot=args.robot,
        task=args.task,
        skill=args.skill,
        outcome=args.outcome,
        text=args.grep,
    )


def _events(args: argparse.Namespace) -> int:
    from ..eventlog import EventLogClient, EventLogError

    if args.export and args.follow:
        raise SystemExit("--export writes what is stored; it cannot --follow")

    async def main() -> int:
        async with mesh_session(args) as mesh:
            client = EventLogClient(mesh, timeout=args.timeout)
            try:
                if args.info:
                    _print_info(await client.info())
                    return 0
                records = client.records(_filter(args), follow=args.follow)
                if args.export:
                    return await _export(records, args.export)
                async for record in records:
                    print(_line(record, args.json), flush=True)
            except EventLogError as e:
                print(f"skimesh events: {e}", file=sys.stderr)
                return 3
        return 0

    try:
        return anyio.run(main)
    except KeyboardInterrupt:
        return 130
    except BrokenPipeError:  # `skimesh events | head`: the reader has what it wanted
        os.dup2(os.open(os.devnull, os.O_WRONLY), sys.stdout.fileno())
        return 0


async def _export(records: AsyncIterator[EventRecord], path: str) -> int:
    from ..eventlog import export_format, write_jsonl, write_parquet

    collected: list[EventRecord] = [r async for r in records]
    if export_format(path) == "parquet":
        count = await anyio.to_thread.run_sync(write_parquet, collected, path)
    else:

        def write() -> int:
            with open(path, "wb") as out:
                return write_jsonl(collected, out)

        count = await anyio.to_thread.run_sync(write)
    print(f"{count} records written to {path}", file=sys.stderr)
    return 0


def _line(record: EventRecord, as_json: bool) -> str:
    if as_json:
        import msgspec

        return msgspec.json.encode(record).decode()
    when = datetime.fromtimestamp(record.stamp).isoformat(sep=" ", timespec="milliseconds")
    where = "/".join(p for p in (record.task, record.robot) if p) or "-"
    return f"{when}  {record.kind:<6} {where:<24} {record.text}"


def _print_info(info: LogInfoReply) -> None:
    span = ""
    if info.count:
        first = datetime.fromtimestamp(info.first_stamp).isoformat(sep=" ", timespec="seconds")
        last = datetime.fromtimestamp(info.last_stamp).isoformat(sep=" ", timespec="seconds")
        span = f" from {first} to {last}"
    print(
        f"{info.count} records{span}; world model to revision {info.wm_revision}; "
        f"kept in {info.path}"
    )
