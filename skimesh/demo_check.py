"""Does the goal really hold? Each goal fact checked in the world model and in the physics.

The task agent's verdict rests on the world model, which the skills' post-conditions wrote. The
demo also asks the simulation (ground truth the skills never read):

- ``contain(C, X)`` between two objects of the world: ``X`` lies in ``C`` at rest, not held
  (:meth:`SimWorld.object_in`: inside the inner footprint, between floor and rim);
- ``doorOpen(A)`` / ``heating(A)`` of an appliance: its device state (door angle, heater);
- anything else (``heated(MealBox-1)``: the simulation has no temperatures) is a world-model
  fact only, and says so.

:func:`verify_goal` lets the world settle for ``settle`` simulated seconds first, so a part
still rolling into its box is judged at rest.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

from device_drivers.interfaces import ApplianceState
from device_drivers.world import SimWorld
from skill_agent.skill import WorldView
from task_agent.goals import Goal, GoalLiteral, PropertyGoal, RelationGoal

__all__ = ["FactCheck", "goal_holds", "verify_goal"]

LabelOf = Callable[[str], str]


@dataclass(frozen=True)
class FactCheck:
    fact: str
    """The goal literal, with labels."""
    in_wm: bool
    physics: bool | None
    """None: the simulation cannot tell (a world-model fact only)."""
    detail: str

    @property
    def holds(self) -> bool:
        return self.in_wm and self.physics is not False


def goal_holds(checks: list[FactCheck]) -> bool:
    """Every fact holds in the world model, and none is contradicted by the physics."""
    return bool(checks) and all(c.holds for c in checks)


def _in_wm(lit: GoalLiteral, view: WorldView) -> bool:
    if isinstance(lit, RelationGoal):
        found = bool(view.query_relation(lit.subject, lit.predicate, lit.object))
        return found == lit.holds
    element = view.find_element(lit.element)
    value = element.properties.get(lit.property) if element is not None else None
    if isinstance(lit.value, bool) and value is None:
        value = False  # an unset boolean property is false (as the planner reads it)
    return (value == lit.value) == lit.holds


def _appliance(world: SimWorld, label: str) -> ApplianceState | None:
    for key, kind in world.devices.items():
        if kind == "appliance" and world.label(key) == label:
            state = world.state(key)
            return state if isinstance(state, ApplianceState) else None
    return None


def _physics(lit: GoalLiteral, world: SimWorld, label_of: LabelOf) -> tuple[bool | None, str]:
    objects = world.facts.objects
    if isinstance(lit, RelationGoal) and lit.predicate == "contain":
        holder, thing = label_of(lit.subject), label_of(lit.object)
        if holder in objects and thing in objects:
            inside = world.object_in(thing, holder)
            where = world.body_pose(thing)
            seen = f"{thing} {'lies' if inside else 'does not lie'} in {holder}"
            return inside == lit.holds, f"{seen} (at {where.x:.3f}, {where.y:.3f}, {where.z:.3f})"
    if isinstance(lit, PropertyGoal) and lit.property in ("doorOpen", "heating"):
        state = _appliance(world, label_of(lit.element))
        if state is not None:
            actual = state.door_open if lit.property == "doorOpen" else state.heating
            text = (
                f"door {'open' if state.door_open else 'closed'} ({state.door_angle:.2f} rad)"
                if lit.property == "doorOpen"
                else f"heater {'on' if state.heating else 'off'}"
            )
            return (actual == lit.value) == lit.holds, text
    return None, "world model only (the simulation cannot tell)"


def _fact(lit: GoalLiteral, label_of: LabelOf) -> str:
    if isinstance(lit, RelationGoal):
        neg = "" if lit.holds else "not "
        return f"{neg}{lit.predicate}({label_of(lit.subject)}, {label_of(lit.object)})"
    op = "=" if lit.holds else "!="
    value = str(lit.value).lower() if isinstance(lit.value, bool) else lit.value
    return f"{lit.property}({label_of(lit.element)}) {op} {value}"


async def verify_goal(
    goal: Goal, view: WorldView, world: SimWorld, label_of: LabelOf, *, settle: float = 0.5
) -> list[FactCheck]:
    """Check every literal of ``goal`` (see the module doc)."""
    if world.failure is None:
        await world.sleep(settle)
    checks = []
    for lit in goal.literals:
        physics, detail = _physics(lit, world, label_of)
        checks.append(FactCheck(_fact(lit, label_of), _in_wm(lit, view), physics, detail))
    return checks
