"""``skimesh task-agent`` (the planning / execution service, with the operator agent) and the
task CLI: ``skimesh task submit|status|list|abort|pause|resume|watch|verify``.

``skimesh task watch TASK`` on a running or finished task prints the task's history first
(``TaskStarted``, the plan, every step so far, times from the task's own start), then follows
it live, each event once. ``task pause TASK`` holds a task (no new step starts; its running
runs are paused on their agents) until ``task resume TASK``; ``task abort`` works while paused.

``skimesh task submit --goal TEXT`` (or ``--file TASK.toml``) follows the task to its end with
one line per event (per robot and per step: started, progress, finished; replanning) and a
summary (outcome, steps, replans, busy time per robot); ``--json`` prints every event as one
JSON line instead. Ctrl-C (or SIGTERM) aborts the task (every run is stopped and its robot
brought to a safe state) before the command exits.

A goal task that succeeded is checked fact by fact by the task agent (in the world model and,
when ``skimesh sim`` runs on the mesh, in the physics, with the simulated time of the check);
``submit``, ``watch`` and ``status`` print each fact's verdicts.

Exit codes: the one table of :class:`skimesh.errors.Exit` (README, "Exit codes"): for
``submit`` and ``watch`` 0 succeeded, 1 failed, 2 unsolvable (or refused: a bad goal, a task
file that does not verify), 3 no task agent answered, 4 aborted, 5 succeeded in the world
model but the physics contradicts a goal fact, 6 partial (an agent was lost; the goal facts
still reachable were achieved), 130 interrupted (the task was aborted).
"""

from __future__ import annotations

import argparse
import sys
import time
from collections.abc import AsyncIterator, Awaitable, Callable
from pathlib import Path
from typing import Any

import anyio
import msgspec

from meshlink import MeshlinkError, add_mesh_arguments
from task_agent import TaskClient, TaskError, VerificationError, new_task_id
from task_agent.protocol import (
    StepProgress,
    TaskEvent,
    TaskFinished,
    TaskInfo,
    TaskOptions,
)
from wm_store import WmClient, WmError, ZenohTransport

from ..errors import Exit, complain, exit_code
from ..runtime import run_service
from . import _plan as plan_command
from . import operator as operator_command
from ._connect import mesh_session, store_answers, wm_session
from ._render import plain_help
from ._table import print_table
from ._task_output import ProgressPrinter, info_lines, print_json, print_problems

__all__ = ["EXIT_CODES", "add_parser"]

Sub = argparse._SubParsersAction  # argparse keeps the sub-parsers action class private
#: A finished task's exit code by its outcome (the table: :class:`skimesh.errors.Exit`).
EXIT_CODES = {
    "succeeded": Exit.OK,
    "failed": Exit.FAILED,
    "unsolvable": Exit.REFUSED,
    "aborted": Exit.ABORTED,
    "partial": Exit.PARTIAL,
}
EXIT_CONTRADICTED, EXIT_INTERRUPTED = Exit.CONTRADICTED, Exit.INTERRUPTED


def add_parser(sub: Sub[argparse.ArgumentParser]) -> None:
    """Add ``task-agent``, ``task`` and ``operator``."""
    agent = sub.add_parser(
        "task-agent",
        help="run the task agent: planning, multi-robot execution, the operator agent",
        description="Serve tasks/rpc: plan goals, run task files, replan on failure; also "
        "serves the operator agent (semi-autonomy) unless --no-operator. Stops cleanly on "
        "Ctrl-C / SIGTERM (running tasks are aborted, their runs stopped).",
    )
    add_mesh_arguments(agent)
    agent.add_argument(
        "--timeout",
        type=float,
        default=5.0,
        metavar="S",
        help="seconds to wait for the world-model store to answer (default: 5)",
    )
    agent.add_argument(
        "--operator",
        default="operator",
        metavar="NAME",
        help="name of the operator agent served here, which hands failed steps to a person "
        "(default: operator)",
    )
    agent.add_argument(
        "--grace",
        type=float,
        default=15.0,
        metavar="S",
        help="seconds agents whose liveliness tokens vanish together (a lost router or a "
        "partition, not dead robots) stay 'unknown' before they count as lost; their runs "
        "go on meanwhile (default: 15)",
    )
    agent.add_argument(
        "--no-operator",
        action="store_true",
        help="serve no operator agent (no step can fall back to a person)",
    )
    agent.add_argument(
        "--durations",
        type=Path,
        metavar="FILE",
        help="keep the learned run times of every (robot, skill) in this JSON file, across "
        "restarts (default: learned in memory only)",
    )
    agent.add_argument(
        "--no-preemption",
        action="store_true",
        help="a running task always keeps what it holds until it ends (default: a waiting "
        "task of higher priority takes it at the running task's next step boundary)",
    )
    agent.set_defaults(func=_serve)

    task = sub.add_parser("task", help="submit, follow, list and abort tasks")
    _client_arguments(task, repeat=False)
    cmds = task.add_subparsers(dest="task_command", metavar="COMMAND")
    task.set_defaults(func=lambda _a: _usage(task))

    submit = cmds.add_parser(
        "submit",
        help="submit a goal or a task file and follow it to its end",
        description="A succeeded goal is checked fact by fact in the world model and, when a "
        "simulator runs on the mesh, in the physics. Exit codes: 0 succeeded, 1 failed, "
        "2 unsolvable (or a usage error, an unknown element), 3 no task agent answered, "
        "4 aborted, 5 succeeded in the world model but contradicted by the physics, "
        "6 partial (an agent was lost: the goal facts still reachable were achieved, the "
        "others lost), 130 interrupted (the task is aborted first).",
    )
    what = submit.add_mutually_exclusive_group(required=True)
    what.add_argument("--goal", help='world-model facts, e.g. "contain(KitBox-1, Gear-3)"')
    what.add_argument("--file", type=Path, help="a task file (TOML sequence/parallel blocks)")
    submit.add_argument(
        "--task-id",
        default="",
        metavar="ID",
        help="name the task (letters, digits, _ . -); default: a fresh t-<hex> id",
    )
    submit.add_argument(
        "--engine",
        choices=("kairos", "fast-downward"),
        default="kairos",
        help="planner that turns the goal into steps: kairos (in-process, fastest; the "
        "default) or fast-downward (a separate process per plan); ignored with --file",
    )
    submit.add_argument(
        "--planning",
        choices=("decomposed", "monolithic"),
        default="decomposed",
        help="decomposed (the default): the goal's independent parts go to robots first and "
        "are planned as small problems, the whole task only when one has no plan; "
        "monolithic: the whole task at once; ignored with --file",
    )
    submit.add_argument(
        "--planner-timeout",
        type=float,
        default=30.0,
        metavar="S",
        help="give up planning after S seconds (each plan and replan; default: 30); the task "
        "then fails with the reason",
    )
    submit.add_argument(
        "--max-replans",
        type=int,
        default=3,
        metavar="N",
        help="when a step fails (a condition, a skill error, a robot lost), plan again from "
        "the world model at most N times before the task fails (default: 3; 0: never)",
    )
    submit.add_argument(
        "--simulate",
        action="store_true",
        help="run every skill in simulated-outcome mode: no hardware moves, success is drawn "
        "and its effects written to the world model",
    )
    submit.add_argument(
        "--operator-fallback",
        nargs="?",
        const="*",
        default="",
        metavar="SKILLS",
        help="when a step fails, hand it to a person through the operator agent (answered "
        "with `skimesh operator`): any step, or only steps of SKILLS (comma-separated skill "
        "names, e.g. pick,place); default: never, the goal is replanned instead",
    )
    submit.add_argument(
        "--priority",
        type=int,
        default=0,
        metavar="N",
        help="among tasks that wait for the same robots or objects, a higher N goes first "
        "(default: 0); a running task of lower priority gives way at its next step boundary "
        "(unless it was submitted with --no-preempt), then plans again and finishes",
    )
    submit.add_argument(
        "--no-preempt",
        action="store_true",
        help="this task keeps what it holds until it ends, whatever waits for it",
    )
    submit.add_argument(
        "--detach",
        action="store_true",
        help="print the task id and return at once (follow it later with `task watch ID`)",
    )
    submit.add_argument(
        "--emit-pddl", type=Path, metavar="DIR", help="also write the goal's PDDL into DIR"
    )
    _follow_arguments(submit)
    _client_arguments(submit)
    submit.set_defaults(func=lambda a: _client(a, _submit))

    status = cmds.add_parser("status", help="one task's state")
    status.add_argument("task_id", metavar="TASK_ID", help="the id `task submit` printed")
    _client_arguments(status)
    status.set_defaults(func=lambda a: _client(a, _status))

    listing = cmds.add_parser("list", help="the tasks the task agent knows")
    listing.add_argument(
        "--active", action="store_true", help="running tasks only (default: finished ones too)"
    )
    _client_arguments(listing)
    listing.set_defaults(func=lambda a: _client(a, _list))

    abort = cmds.add_parser(
        "abort",
        help="stop every run of a task (robots to a safe state)",
        description="Stop every run of a task; each robot is brought to a safe state. Returns "
        "once the task ended. Exit codes: 0 the task has ended (aborted now, or it had ended "
        "already), 1 still running after the wait, 2 no such task, 3 no task agent answered.",
    )
    abort.add_argument("task_id", metavar="TASK_ID", help="the task to stop")
    abort.add_argument(
        "--reason",
        default="aborted from the command line",
        help="why, recorded as the task's final message",
    )
    _client_arguments(abort)
    abort.set_defaults(func=lambda a: _client(a, _abort))

    pause = cmds.add_parser(
        "pause",
        help="hold a task: pause its runs, start no new step until `task resume`",
        description="Hold a running task: every run of the task is paused on its agent (held "
        "at its next checkpoint) and no new step starts until `skimesh task resume`. "
        "`task abort` works while paused. Exit codes: 0 paused (or paused already), 4 errors "
        "(no such task, the task has ended, no task agent).",
    )
    pause.add_argument("task_id", metavar="TASK_ID", help="the task to hold")
    pause.add_argument("--reason", default="paused from the command line", help="why")
    _client_arguments(pause)
    pause.set_defaults(func=lambda a: _client(a, _hold))

    resume = cmds.add_parser(
        "resume",
        help="release a paused task: its runs go on, new steps start",
        description="Release a task held by `skimesh task pause`: its paused runs go on and "
        "the steps that became ready start. Exit codes: 0 resumed (or not paused), 4 errors.",
    )
    resume.add_argument("task_id", metavar="TASK_ID", help="the task to release")
    _client_arguments(resume)
    resume.set_defaults(func=lambda a: _client(a, _hold))

    watch = cmds.add_parser(
        "watch",
        help="follow a task: its history so far, then live (exit codes as for submit)",
        description="Print a running or finished task's history (the plan and every event so "
        "far, times from the task's start), then follow it live to its end. Exit codes as "
        "for `task submit`.",
    )
    watch.add_argument("task_id", metavar="TASK_ID", help="the task to follow")
    _follow_arguments(watch)
    _client_arguments(watch)
    watch.set_defaults(func=lambda a: _client(a, _watch))

    verify = cmds.add_parser("verify", help="verify a task file against the world model")
    verify.add_argument("file", type=Path, metavar="FILE", help="the task file (TOML) to check")
    _client_arguments(verify)
    verify.set_defaults(func=lambda a: _client(a, _verify))

    plan = cmds.add_parser(
        "plan",
        help="plan a goal without running it (prints the schedule; --emit-pddl DIR)",
        description=plain_help(plan_command.__doc__),
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    plan_command.add_arguments(plan)
    _client_arguments(plan)
    plan.set_defaults(func=lambda a: _client(a, plan_command.plan_goal))

    operator_command.add_parser(sub)


def _follow_arguments(p: argparse.ArgumentParser) -> None:
    p.add_argument(
        "--deadline",
        type=float,
        default=3600.0,
        metavar="S",
        help="stop following after S seconds (exit 3; the task goes on; default: 3600)",
    )
    p.add_argument(
        "--no-progress",
        action="store_true",
        help="leave out the progress lines within a step (keep started / finished)",
    )


def _client_arguments(p: argparse.ArgumentParser, *, repeat: bool = True) -> None:
    """The options of every ``task`` command, on ``skimesh task`` itself (``repeat=False``:
    with their defaults) and again on each of its commands (set only where given), so they
    may come before or after the command: ``skimesh task --connect E list`` or ``skimesh task
    list --connect E``."""
    add_mesh_arguments(p, repeat=repeat)
    given: dict[str, Any] = {"default": argparse.SUPPRESS} if repeat else {}
    p.add_argument(
        "--timeout",
        type=float,
        metavar="S",
        help="seconds to wait for the task agent to answer a request (default: 5)",
        **(given or {"default": 5.0}),
    )
    p.add_argument(
        "--json",
        action="store_true",
        help="machine-readable output (JSON, one per line)",
        **given,
    )


def _usage(parser: argparse.ArgumentParser) -> int:
    parser.print_help(sys.stderr)
    return Exit.REFUSED


# --------------------------------------------------------------------------- task-agent


def _serve(args: argparse.Namespace) -> int:
    from task_agent.service import serve_tasks  # slow to import (docs/benchmarks.md, Planning)

    async def main() -> int:
        try:
            async with mesh_session(args) as mesh:
                await store_answers(mesh, "task agent", timeout=args.timeout)
                async with WmClient.connect(
                    ZenohTransport(mesh), author="task-agent", timeout=args.timeout
                ) as wm:
                    await serve_tasks(  # until cancelled
                        mesh,
                        wm,
                        operator=None if args.no_operator else args.operator,
                        grace=args.grace,
                        durations=args.durations,
                        preemption=not args.no_preemption,
                    )
        except (WmError, MeshlinkError) as e:
            print(f"skimesh task-agent: {e}", file=sys.stderr)
            return exit_code(e)
        return 0

    return run_service(main)


# --------------------------------------------------------------------------- output


# --------------------------------------------------------------------------- commands


def _client(args: argparse.Namespace, body: Callable[[argparse.Namespace], Awaitable[int]]) -> int:
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


async def _submit(args: argparse.Namespace) -> int:
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
                return await _follow(args, events)
            except anyio.get_cancelled_exc_class():
                with anyio.CancelScope(shield=True), anyio.move_on_after(args.timeout + 15):
                    print(f"aborting task {task_id} ...", file=sys.stderr)
                    print(await client.abort(task_id, "interrupted (Ctrl-C)"), file=sys.stderr)
                raise


async def _follow(args: argparse.Namespace, events: AsyncIterator[TaskEvent]) -> int:
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


async def _watch(args: argparse.Namespace) -> int:
    async with mesh_session(args) as mesh:
        client = TaskClient(mesh, timeout=args.timeout)
        async with client.watch(args.task_id, deadline=args.deadline) as events:
            return await _follow(args, events)


async def _status(args: argparse.Namespace) -> int:
    async with mesh_session(args) as mesh:
        info = await TaskClient(mesh, timeout=args.timeout).status(args.task_id)
    if args.json:
        print_json(info)
    else:
        print("\n".join(info_lines(info)))
    return 0


async def _list(args: argparse.Namespace) -> int:
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


async def _abort(args: argparse.Namespace) -> int:
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


async def _hold(args: argparse.Namespace) -> int:
    """``task pause`` / ``task resume``: the service's answer."""
    async with mesh_session(args) as mesh:
        client = TaskClient(mesh, timeout=args.timeout)
        if args.task_command == "pause":
            message = await client.pause(args.task_id, args.reason)
        else:
            message = await client.resume(args.task_id)
    print_json({"task_id": args.task_id, "reply": message}) if args.json else print(message)
    return 0


async def _verify(args: argparse.Namespace) -> int:
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
