"""``skimesh operator``: the person's side of semi-autonomy (FRIEND II).

When a step fails and its task allows it, the task agent hands the step to the operator agent,
which holds it as a *pending request* until a person answers. This command lists the pending
requests and answers them:

- ``skimesh operator``: list them (on a terminal: answer them one by one as they come,
  ``s``/``success`` or ``f``/``failure``, optionally followed by a message; Ctrl-D ends);
- ``skimesh operator --wait 30``: first wait up to 30 s for a request (scripts);
- ``skimesh operator --answer ID success|failure [--message TEXT] [--seen LABEL=X,Y,Z]``:
  answer one; ``--seen`` tells where you see an element (e.g. the meal box no camera found),
  written to the world model as your observation.

Exit codes: 0 done, 1 ``--wait`` saw no request in time, 2 a bad answer or an unknown request
id, 3 no operator agent answered. Ctrl-C / SIGTERM ends it cleanly.
"""

from __future__ import annotations

import argparse
import asyncio
import os
import sys
import time
from collections.abc import AsyncIterator
from contextlib import asynccontextmanager

import anyio
import msgspec

from meshlink import Mesh, MeshlinkError, Sample, Subscription, add_mesh_arguments
from task_agent import OperatorClient, TaskError
from task_agent.protocol import PendingStep, SeenAt

from ..errors import Exit, UsageError, complain, exit_code
from ..runtime import run_service
from ._connect import mesh_session
from ._render import plain_help

__all__ = ["add_parser"]

Sub = argparse._SubParsersAction  # argparse keeps the sub-parsers action class private
EXIT_NONE = Exit.FAILED
VERDICTS = {"s": True, "success": True, "done": True, "f": False, "failure": False}


def add_parser(sub: Sub[argparse.ArgumentParser]) -> None:
    p = sub.add_parser(
        "operator",
        help="list the steps waiting for a person and answer them (semi-autonomy)",
        description=plain_help(__doc__.split("\n\n", 1)[1] if __doc__ else None),
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    add_mesh_arguments(p)
    p.add_argument(
        "--timeout",
        type=float,
        default=5.0,
        metavar="S",
        help="seconds to wait for the operator agent to answer a request (default: 5)",
    )
    p.add_argument(
        "--json", action="store_true", help="list the pending requests as one JSON array"
    )
    p.add_argument(
        "--answer",
        nargs=2,
        metavar=("ID", "VERDICT"),
        help="answer request ID (the [id] listed) with VERDICT success (the person did the "
        "step: it counts as done) or failure (the step fails)",
    )
    p.add_argument(
        "--message",
        default="",
        help="with --answer: what was done, or why not (in the task's events)",
    )
    p.add_argument(
        "--seen",
        action="append",
        default=[],
        type=seen_at,
        metavar="LABEL=X,Y,Z[,YAW]",
        help="with --answer: where you see an element (its centre, world metres; heading in "
        "rad), e.g. MealBox-1=0.77,-0.40,0.78 when no camera finds it; repeatable. Written to "
        "the world model as your observation, which `locate` uses when its sensors see nothing",
    )
    p.add_argument(
        "--wait",
        type=float,
        metavar="S",
        help="first wait up to S seconds for a request to come (exit 1 if none does)",
    )
    p.add_argument(
        "-i",
        "--interactive",
        action="store_true",
        help="answer requests as they come, one input line each (the default on a terminal)",
    )
    p.add_argument(
        "--agent",
        default="operator",
        metavar="NAME",
        help="the operator agent's name, as given to `skimesh task-agent --operator` "
        "(default: operator)",
    )
    p.set_defaults(func=_main)


def _main(args: argparse.Namespace) -> int:
    async def main() -> int:
        try:
            async with mesh_session(args) as mesh:
                client = OperatorClient(mesh, timeout=args.timeout)
                if args.answer:
                    return await _answer(client, *args.answer, message=args.message, seen=args.seen)
                if args.seen:
                    complain(args, "--seen goes with --answer")
                    return Exit.REFUSED
                interactive = args.interactive or (
                    sys.stdin.isatty() and not args.json and args.wait is None
                )
                async with _wakeups(mesh, args.agent) as wakeups:
                    if interactive:
                        return await _interactive(client, wakeups)
                    return await _list(args, client, wakeups)
        except (TaskError, MeshlinkError) as e:
            complain(args, str(e))
            return exit_code(e)

    return run_service(main)


@asynccontextmanager
async def _wakeups(mesh: Mesh, agent: str) -> AsyncIterator[Subscription[Sample]]:
    """The operator agent's run progress: a new request publishes one (no polling)."""
    async with mesh.subscribe(mesh.keys.runs_progress(agent)) as samples:
        yield samples


async def _changed(wakeups: Subscription[Sample], timeout: float) -> None:
    """Until the operator agent reports something (or ``timeout`` s, a safety net)."""
    with anyio.move_on_after(timeout):
        await wakeups.receive()
    while True:
        try:
            wakeups.receive_nowait()
        except anyio.WouldBlock:
            return


def _line(step: PendingStep) -> str:
    args = ", ".join(f"{k}={v}" for k, v in step.params.items())
    age = time.time() - step.asked_at
    return f"[{step.id}] {step.skill}({args})  waiting {age:.0f} s\n    {step.note}"


def seen_at(text: str) -> SeenAt:
    """``LABEL=X,Y,Z[,YAW]`` -> :class:`SeenAt` (argparse type: a clear error otherwise)."""
    label, sep, numbers = text.partition("=")
    try:
        values = [float(v) for v in numbers.split(",")] if sep else []
    except ValueError:
        values = []
    if not label.strip() or len(values) not in (3, 4):
        raise argparse.ArgumentTypeError(
            f"{text!r}: expected LABEL=X,Y,Z or LABEL=X,Y,Z,YAW (metres, radians)"
        )
    x, y, z = values[:3]
    return SeenAt(
        element=label.strip(), position=(x, y, z), yaw=values[3] if len(values) == 4 else None
    )


async def _answer(
    client: OperatorClient,
    request_id: str,
    verdict: str,
    *,
    message: str,
    seen: list[SeenAt],
) -> int:
    if verdict.lower() not in VERDICTS:
        raise UsageError(f"the verdict is 'success' or 'failure', not {verdict!r}")
    success = VERDICTS[verdict.lower()]
    print(await client.answer(request_id, success, message, author="cli", seen=seen))
    return 0


async def _list(
    args: argparse.Namespace, client: OperatorClient, wakeups: Subscription[Sample]
) -> int:
    pending = await client.pending()
    if args.wait is not None:
        deadline = anyio.current_time() + args.wait
        while not pending and anyio.current_time() < deadline:
            await _changed(wakeups, min(1.0, max(0.0, deadline - anyio.current_time())))
            pending = await client.pending()
    if args.json:
        sys.stdout.write(msgspec.json.encode(pending).decode() + "\n")
    elif pending:
        print("\n".join(_line(step) for step in pending))
    else:
        print("no step is waiting for the operator")
    return 0 if pending or args.wait is None else EXIT_NONE


async def _interactive(client: OperatorClient, wakeups: Subscription[Sample]) -> int:
    """Show requests as they come; each input line answers one: ``s|f [ID] [message]``
    (without an ID: the oldest request). End of input (Ctrl-D) ends."""
    print("answer with: s[uccess] or f[ailure], optionally the request id, then a message")
    async with _stdin_lines() as lines, anyio.create_task_group() as tg:
        tg.start_soon(_show_requests, client, wakeups)
        while line := (await lines.readline()).decode():
            words = line.split()
            if not words:
                continue
            if words[0].lower() not in VERDICTS:
                print("  type s (success) or f (failure), then optionally the id and a message")
                continue
            pending = [s.id for s in await client.pending()]
            chosen = words[1] if len(words) > 1 and words[1] in pending else ""
            request_id = chosen or (pending[0] if pending else "")
            if not request_id:
                print("  no request is waiting")
                continue
            message = " ".join(words[2:] if chosen else words[1:])
            try:
                verdict = VERDICTS[words[0].lower()]
                print("  " + await client.answer(request_id, verdict, message, "cli"))
            except TaskError as e:  # withdrawn meanwhile (the task was aborted)
                print(f"  {e}")
        tg.cancel_scope.cancel()
    return 0


async def _show_requests(client: OperatorClient, wakeups: Subscription[Sample]) -> None:
    shown: set[str] = set()
    while True:
        for step in await client.pending():
            if step.id not in shown:
                shown.add(step.id)
                print(_line(step), flush=True)
        await _changed(wakeups, 2.0)


@asynccontextmanager
async def _stdin_lines() -> AsyncIterator[asyncio.StreamReader]:
    """Standard input as an asyncio stream (no thread: a blocked reading thread would keep
    the process alive after Ctrl-C). The blocking mode of the descriptor is restored."""
    loop = asyncio.get_running_loop()
    reader = asyncio.StreamReader()
    fd = sys.stdin.fileno()
    blocking = os.get_blocking(fd)
    transport, _ = await loop.connect_read_pipe(
        lambda: asyncio.StreamReaderProtocol(reader), sys.stdin
    )
    try:
        yield reader
    finally:
        transport.close()
        os.set_blocking(fd, blocking)
