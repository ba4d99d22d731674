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
from pathlib import Path
from typing import Any

from meshlink import MeshlinkError, add_mesh_arguments
from wm_store import WmClient, WmError, ZenohTransport

from ..errors import Exit, exit_code
from ..runtime import run_service
from . import _plan as plan_command
from . import _tasks as tasks
from . import operator as operator_command
from ._connect import service_mesh, store_answers
from ._render import plain_help

__all__ = ["add_parser"]

Sub = argparse._SubParsersAction  # argparse keeps the sub-parsers action class private


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
    submit.set_defaults(func=lambda a: tasks.client(a, tasks.submit))

    status = cmds.add_parser("status", help="one task's state")
    status.add_argument("task_id", metavar="TASK_ID", help="the id `task submit` printed")
    _client_arguments(status)
    status.set_defaults(func=lambda a: tasks.client(a, tasks.status))

    listing = cmds.add_parser("list", help="the tasks the task agent knows")
    listing.add_argument(
        "--active", action="store_true", help="running tasks only (default: finished ones too)"
    )
    _client_arguments(listing)
    listing.set_defaults(func=lambda a: tasks.client(a, tasks.listing))

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
    abort.set_defaults(func=lambda a: tasks.client(a, tasks.abort))

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
    pause.set_defaults(func=lambda a: tasks.client(a, tasks.hold))

    resume = cmds.add_parser(
        "resume",
        help="release a paused task: its runs go on, new steps start",
        description="Release a task held by `skimesh task pause`: its paused runs go on and "
        "the steps that became ready start. Exit codes: 0 resumed (or not paused), 4 errors.",
    )
    resume.add_argument("task_id", metavar="TASK_ID", help="the task to release")
    _client_arguments(resume)
    resume.set_defaults(func=lambda a: tasks.client(a, tasks.hold))

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
    watch.set_defaults(func=lambda a: tasks.client(a, tasks.watch))

    verify = cmds.add_parser("verify", help="verify a task file against the world model")
    verify.add_argument("file", type=Path, metavar="FILE", help="the task file (TOML) to check")
    _client_arguments(verify)
    verify.set_defaults(func=lambda a: tasks.client(a, tasks.verify))

    plan = cmds.add_parser(
        "plan",
        help="plan a goal without running it (prints the schedule; --emit-pddl DIR)",
        description=plain_help(plan_command.__doc__),
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    plan_command.add_arguments(plan)
    _client_arguments(plan)
    plan.set_defaults(func=lambda a: tasks.client(a, plan_command.plan_goal))

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
            async with service_mesh(args, "task agent") as mesh:
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
