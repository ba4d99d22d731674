"""The task client commands: ``skimesh task submit|status|list|abort|pause|resume|watch|
verify|plan`` (their parsers are in ``task``; the module doc there says what each does).

:func:`client` runs one of them with the errors of the exit-code table; :func:`follow` prints a
task's events to its end (the live view on a terminal, a line per event into a pipe, JSON
lines) and gives the exit code of its outcome (:data:`EXIT_CODES`)."""

from __future__ import annotations

import argparse
import sys
import time
from collections.abc import AsyncIterator, Awaitable, Callable

import anyio
import msgspec

from meshlink import MeshlinkError
from task_agent import TaskClient, TaskError, VerificationError, new_task_id
from task_agent.protocol import (
    StepProgress,
    TaskEvent,
    TaskFinished,
    TaskInfo,
    TaskOptions,
)

from ..errors import Exit, complain, exit_code
from ..runtime import run_service
from . import _plan as plan_command
from ._connect import mesh_session, wm_session
from ._table import print_table
from ._task_output import ProgressPrinter, info_lines, print_json, print_problems

__all__ = [
    "EXIT_CODES",
    "EXIT_CONTRADICTED",
    "abort",
    "client",
    "follow",
    "hold",
    "listing",
    "status",
    "submit",
    "verify",
    "watch",
]

#: A finished task's exit code by its outcome (the table: :class:`skimesh.errors.Exit`).
EXIT_CODES = {
    "succeeded": Exit.OK,
    "failed": Exit.FAILED,
    "unsolvable": Exit.REFUSED,
    "aborted": Exit.ABORTED,
    "partial": Exit.PARTIAL,
}
EXIT_CONTRADICTED, EXIT_INTERRUPTED = Exit.CONTRADICTED, Exit.INTERRUPTED


def client(args: argparse.Namespace, body: Callable[[argparse.Namespace], Awaitable[int]]) -> int:
    interrupted: list[bool] = []

    async def main() -> int:
        try:
            return await body(args)
        except anyio.get_cancelled_exc_class():
            interrupted.append(True)
            raise
        except VerificationError as e:
            complain(args, str(e))
            print_problems(getattr(e, "problems", []))
            return Exit.REFUSED
        except (TaskError, MeshlinkError, OSError) as e:
            complain(args, str(e))
            return exit_code(e)
        except TimeoutError:
            deadline = getattr(args, "deadline", None)
            within = f"--deadline {deadline:g} s" if deadline else f"--timeout {args.timeout:g} s"
            complain(args, f"no end of the task within {within}")
            return Exit.UNREACHABLE

    code = run_service(main)
    if interrupted:
        print("interrupted", file=sys.stderr)
        return EXIT_INTERRUPTED
    return code


def _options(args: argparse.Namespace) -> TaskOptions:
    fallback = frozenset(s.strip() for s in args.operator_fallback.split(","))
    return TaskOptions(
        engine=args.engine,
        planner_timeout=args.planner_timeout,
        planning=args.planning,
        max_replans=args.max_replans,
        simulate=args.simulate,
        operator_fallback="*" in fallback,
        operator_fallback_skills=fallback - {"", "*"},
        priority=args.priority,
        preemptible=not args.no_preempt,
    )


async def submit(args: argparse.Namespace) -> int:
    text = args.file.read_text(encoding="utf-8") if args.file else ""
    task_id = args.task_id or new_task_id()
    if args.emit_pddl and args.goal:
        async with wm_session(args, author="planner-cli") as wm:
            for path in await plan_command.emit_pddl(wm, args.goal, args.engine, args.emit_pddl):
                print(f"wrote {path}", file=sys.stderr)
    async with mesh_session(args) as mesh:
        client = TaskClient(mesh, timeout=args.timeout)
        async with client.watch(task_id, deadline=args.deadline, existing=False) as events:
            if args.file:
                await client.submit_file(text, options=_options(args), task_id=task_id)
            else:
                await client.submit_goal(args.goal, options=_options(args), task_id=task_id)
            if args.detach:
                print(task_id)
                return 0
            try:
                return await follow(args, events)
            except anyio.get_cancelled_exc_class():
                with anyio.CancelScope(shield=True), anyio.move_on_after(args.timeout + 15):
                    print(f"aborting task {task_id} ...", file=sys.stderr)
                    print(await client.abort(task_id, "interrupted (Ctrl-C)"), file=sys.stderr)
                raise


async def follow(args: argparse.Namespace, events: AsyncIterator[TaskEvent]) -> int:
    if not (args.json or args.no_progress) and sys.stdout.isatty():
        return await _follow_live(events)
    show: Callable[[TaskEvent], None] = print_json if args.json else ProgressPrinter()
    async for event in events:
        if not (args.no_progress and isinstance(event, StepProgress)):
            show(event)
        if isinstance(event, TaskFinished):
            if event.check is not None and event.check.contradicted:
                return EXIT_CONTRADICTED
            return EXIT_CODES.get(event.outcome, Exit.FAILED)
    return Exit.UNREACHABLE  # pragma: no cover - the stream ends with TaskFinished


async def _follow_live(events: AsyncIterator[TaskEvent]) -> int:
    """On a terminal: one live view of the task, then its summary (see ``_live``)."""
    from rich.console import Console

    from ._live import follow_live

    printer = ProgressPrinter()  # keeps the per-robot times for the summary
    finished = await follow_live(events, Console(), on_event=printer.lines)
    if finished is None:  # the stream ended without the task's end
        return Exit.UNREACHABLE
    print("\n".join(printer.lines(finished)))
    if finished.check is not None and finished.check.contradicted:
        return EXIT_CONTRADICTED
    return EXIT_CODES.get(finished.outcome, Exit.FAILED)


async def watch(args: argparse.Namespace) -> int:
    async with mesh_session(args) as mesh:
        client = TaskClient(mesh, timeout=args.timeout)
        async with client.watch(args.task_id, deadline=args.deadline) as events:
            return await follow(args, events)


async def status(args: argparse.Namespace) -> int:
    async with mesh_session(args) as mesh:
        info = await TaskClient(mesh, timeout=args.timeout).status(args.task_id)
    if args.json:
        print_json(info)
    else:
        print("\n".join(info_lines(info)))
    return 0


async def listing(args: argparse.Namespace) -> int:
    async with mesh_session(args) as mesh:
        tasks = await TaskClient(mesh, timeout=args.timeout).list(active_only=args.active)
    if args.json:
        print_json(tasks)
    else:
        print_table(
            ("TASK", "STATE", "PRIO", "HOLDS", "ESTIMATED END", "REPLANS", "GOAL"),
            [_list_row(info) for info in tasks],
        )
    return 0


def _list_row(info: TaskInfo) -> tuple[str, ...]:
    """One row of ``task list``: the task's state (waiting: for what), what it holds (its
    claims: no other task commands them) and when it should end (its start plus the estimated
    makespan, on the task agent's clock)."""
    state: str = info.outcome
    if info.paused:
        state += " (paused)"
    elif info.waiting:
        state = f"waiting for {info.waiting}"
    end = "-"
    if info.outcome == "running" and info.estimated_makespan is not None and info.started_at:
        end = time.strftime("%H:%M:%S", time.localtime(info.started_at + info.estimated_makespan))
    holds = ", ".join(info.claims) or "-"
    return (
        info.task_id,
        state,
        str(info.priority),
        holds,
        end,
        str(info.replans),
        info.goal or info.name,
    )


async def abort(args: argparse.Namespace) -> int:
    """The service answers once the task ended (or its wait ran out): the task's state after
    the abort says which."""
    async with mesh_session(args) as mesh:
        client = TaskClient(mesh, timeout=args.timeout)
        reply = await client.abort(args.task_id, args.reason)
        info = await client.status(args.task_id)
    if args.json:
        print_json({**msgspec.to_builtins(info), "reply": reply})  # the task, and the answer
    else:
        print(reply)
    if info.outcome == "running":
        complain(args, f"task {args.task_id} is still running after the abort")
        return Exit.FAILED
    return 0


async def hold(args: argparse.Namespace) -> int:
    """``task pause`` / ``task resume``: the service's answer."""
    async with mesh_session(args) as mesh:
        client = TaskClient(mesh, timeout=args.timeout)
        if args.task_command == "pause":
            message = await client.pause(args.task_id, args.reason)
        else:
            message = await client.resume(args.task_id)
    print_json({"task_id": args.task_id, "reply": message}) if args.json else print(message)
    return 0


async def verify(args: argparse.Namespace) -> int:
    from task_agent.taskfile import load_task_file

    text = args.file.read_text(encoding="utf-8")
    load_task_file(text, source=str(args.file))  # syntax errors with the line, offline
    async with mesh_session(args) as mesh:
        reply = await TaskClient(mesh, timeout=args.timeout).verify(text)
    if args.json:
        print_json(reply)
    elif reply.ok:
        print(f"{args.file}: verifies")
    else:
        print(f"{args.file}: {len(reply.problems)} problems", file=sys.stderr)
        print_problems(reply.problems)
    return 0 if reply.ok else 1
