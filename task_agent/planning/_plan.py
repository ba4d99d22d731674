"""What planning answers: a :class:`Plan` of agent-tagged :class:`PlanStep` values, with
:class:`PlanStats` on how it was found.

:class:`~task_agent.planning.Planner` makes them; the executor runs the steps (a step names the
agent, its skill and the skill's parameters) and the partial order relaxes their sequence.
Pure data, no planner imports.
"""

from __future__ import annotations

import math
from collections.abc import Collection
from typing import Literal

import msgspec

from ..domain import Lit, PlanningTask
from ..reachability import GroundStep

__all__ = ["Engine", "Plan", "PlanStats", "PlanStep"]

Engine = Literal["kairos", "fast-downward"]
"""The planning engines a :class:`~task_agent.planning.Planner` can use."""


class PlanStep(msgspec.Struct, frozen=True, kw_only=True):
    """One skill run: who, what, with which parameters (skill parameter -> element id,
    hardware included; parameters left out are inferred by the agent)."""

    index: int
    action: str
    agent: str
    skill: str
    args: tuple[str, ...]
    """The action's arguments, in the order of its parameters."""
    params: dict[str, str]
    duration: float

    @property
    def ground(self) -> GroundStep:
        return GroundStep(self.action, self.args)

    def __str__(self) -> str:
        args = ", ".join(f"{k}={v}" for k, v in self.params.items())
        return f"{self.agent}: {self.skill}({args})"


class PlanStats(msgspec.Struct, frozen=True, kw_only=True):
    engine: str
    objects: int
    """Objects of the full task."""
    objects_solved: int
    """Objects of the task the engine solved (fewer when compression applied)."""
    fallback: bool = False
    """The compressed task failed and the full task was solved."""
    convert_s: float = 0.0
    """Building the unified-planning problem."""
    solve_s: float = 0.0
    """The engine call through unified-planning (PDDL writing, parsing, search)."""
    engine_s: float = math.nan
    """The engine's own figure for its work, when it reports one."""
    total_s: float = 0.0
    parts: int = 0
    """Parts of the goal planned apart as small problems (0: the whole task was solved)."""
    part_solves: int = 0
    """Engine calls of the decomposed path."""
    widened: int = 0
    """Parts whose first small problem had no plan that holds on the full task."""
    reused: int = 0
    """Parts whose remaining steps were taken over from the plan before a replan."""

    def summary(self) -> str:
        """One line for a person: how long, how (parts or the whole task), how large."""
        how = (
            f"{self.parts} goal parts in {self.part_solves} small problems "
            f"({self.widened} widened; the largest {self.objects_solved} of "
            f"{self.objects} objects"
            f"{f'; {self.reused} kept from the plan before' if self.reused else ''})"
            if self.parts
            else f"the whole task ({self.objects_solved} of {self.objects} objects"
            f"{', after the compressed one failed' if self.fallback else ''})"
        )
        return f"planned with {self.engine} in {self.total_s:.2f} s: {how}"


class Plan(msgspec.Struct, frozen=True, kw_only=True):
    steps: tuple[PlanStep, ...]
    task: PlanningTask
    stats: PlanStats
    blocks: tuple[tuple[tuple[Lit, ...], tuple[int, ...]], ...] = ()
    """Planned by parts: each group of goal parts planned together, its literals and the
    indices of its steps (a replan passes the remaining ones back: ``Planner.plan(...,
    previous=...)``)."""

    def remaining(
        self, done: Collection[GroundStep]
    ) -> list[tuple[tuple[Lit, ...], list[PlanStep]]]:
        """Each block's literals and its steps not in ``done`` (steps that ran), in order."""
        return [
            (lits, [self.steps[i] for i in indices if self.steps[i].ground not in done])
            for lits, indices in self.blocks
        ]

    @property
    def duration(self) -> float:
        """Estimated seconds when the steps run one after the other."""
        return sum(s.duration for s in self.steps)

    def __str__(self) -> str:
        return "\n".join(f"{s.index + 1:3d}. {s}" for s in self.steps) or "(empty plan)"
