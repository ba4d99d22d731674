"""``skimesh task plan``: plan a goal against the live world model without running it.

A dry run for people who program robots: it reads the world model and the registered agents
(like the task agent does), plans with the chosen engine, prints the partial-order schedule and,
with ``--emit-pddl DIR``, writes ``domain.pddl`` and ``problem.pddl`` for inspection with other
planners. ``skimesh task submit --goal ... --emit-pddl DIR`` writes the same files before it
submits. Exit codes: 0 planned, 1 the planner failed, 2 unsolvable (or bad input), 3 no
answer from the world model.

The text schedule names elements as everything else does (:func:`wm_store.display_name`:
``Camera-1``, or ``Pulley-4 (Gear-1)`` where the label and the id differ); ``--json`` keeps
the ids.
"""

from __future__ import annotations

import argparse
import sys
from collections.abc import Callable
from pathlib import Path
from typing import TYPE_CHECKING

import anyio
import msgspec

from task_agent import PlanningError, UnsolvableError, parse_goal
from task_agent.discovery import agents_from_view
from wm_store import WmClient, display_name
from wm_store.protocol import Element

if TYPE_CHECKING:  # the planners take over a second to import: only when planning
    from task_agent.planning import PartialOrderPlan

from ..errors import Exit
from ._connect import wm_session

__all__ = ["add_arguments", "emit_pddl", "named_order", "plan_goal"]

EXIT_UNSOLVABLE = Exit.REFUSED


def add_arguments(p: argparse.ArgumentParser) -> None:
    p.add_argument(
        "--goal", required=True, help='world-model facts, e.g. "contain(KitBox-1, Gear-3)"'
    )
    p.add_argument(
        "--engine",
        choices=("kairos", "fast-downward"),
        default="kairos",
        help="planner that turns the goal into steps: kairos (in-process, fastest; the "
        "default) or fast-downward (a separate process per plan)",
    )
    p.add_argument(
        "--planning",
        choices=("decomposed", "monolithic"),
        default="decomposed",
        help="decomposed (the default): the goal's independent parts go to robots first and "
        "are planned as small problems, the whole task only when one has no plan; "
        "monolithic: the whole task at once",
    )
    p.add_argument(
        "--planner-timeout",
        type=float,
        default=30.0,
        metavar="S",
        help="give up planning after S seconds (default: 30)",
    )
    p.add_argument("--emit-pddl", type=Path, metavar="DIR", help="write domain.pddl + problem.pddl")


async def emit_pddl(
    wm: WmClient, goal_text: str, engine: str, directory: Path
) -> tuple[Path, Path]:
    """Write the PDDL the task agent would solve for ``goal_text`` now; returns the paths."""
    from task_agent.domain import build_task
    from task_agent.planning import Planner

    goal = parse_goal(goal_text, wm)
    agents = [a for a in agents_from_view(wm) if a.available]
    task = build_task(agents, wm, goal)
    planner = Planner(engine=engine)  # type: ignore[arg-type]  # argparse checked the choice
    return await anyio.to_thread.run_sync(planner.emit_pddl, task, directory)


def named_order(order: PartialOrderPlan, find: Callable[[str], Element | None]) -> PartialOrderPlan:
    """``order`` with each parameter that is an element id (``find`` finds it) replaced by the
    element's :func:`~wm_store.display_name`, for printing."""

    def named(value: str) -> str:
        element = find(value)
        return value if element is None else display_name(element)

    steps = tuple(
        msgspec.structs.replace(
            s,
            step=msgspec.structs.replace(
                s.step, params={k: named(v) for k, v in s.step.params.items()}
            ),
        )
        for s in order.steps
    )
    return msgspec.structs.replace(order, steps=steps)


async def plan_goal(args: argparse.Namespace) -> int:
    """The body of ``skimesh task plan``."""
    from task_agent.planning import Planner, to_partial_order

    async with wm_session(args, author="planner-cli") as wm:
        if args.emit_pddl:
            for path in await emit_pddl(wm, args.goal, args.engine, args.emit_pddl):
                print(f"wrote {path}", file=sys.stderr)
        goal = parse_goal(args.goal, wm)
        agents = [a for a in agents_from_view(wm) if a.available]
        decompose = args.planning == "decomposed"
        planner = Planner(engine=args.engine, timeout=args.planner_timeout, decompose=decompose)
        try:
            plan = await planner.plan(agents, wm, goal)
        except UnsolvableError as e:
            print(f"unsolvable: {e}", file=sys.stderr)
            return EXIT_UNSOLVABLE
        except PlanningError as e:
            print(f"planning failed: {e}", file=sys.stderr)
            return Exit.FAILED
        order = to_partial_order(plan)
        shown = order if args.json else named_order(order, wm.find_element)
        print(plan.stats.summary(), file=sys.stderr)
    if args.json:
        sys.stdout.write(msgspec.json.encode(shown).decode() + "\n")
    else:
        print(shown.render())
    return 0
