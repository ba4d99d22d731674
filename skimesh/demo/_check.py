"""Does the goal really hold? Each goal fact checked in the world model and in the physics.

The task agent's verdict rests on the world model, which the skills' post-conditions wrote. The
demo also asks the simulation (ground truth the skills never read):

- ``contain(C, X)`` between two objects of the world: ``X`` lies in ``C`` at rest, not held
  (:meth:`SimWorld.object_in`: inside the inner footprint, between floor and rim);
- ``doorOpen(A)`` / ``heating(A)`` of an appliance: its device state (door angle, heater);
- anything else (``heated(MealBox-1)``: the simulation has no temperatures) is a world-model
  fact only, and says so.

:func:`verify_goal` lets the world settle first (``settle`` simulated seconds, then until the
objects named are at rest, within a bound), so a part still rolling into its box is judged at
rest; one still moving or held is reported as such.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

from device_drivers import ApplianceState
from mujoco_sim import SimWorld
from skill_agent import WorldView
from task_agent import Goal, GoalLiteral, PropertyGoal, RelationGoal

__all__ = ["FactCheck", "goal_holds", "verify_goal"]

LabelOf = Callable[[str], str]
REST_SPEED = 0.01
"""m/s: an object slower than this is at rest (as :meth:`SimWorld.object_in` judges)."""


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


def _contained(lit: GoalLiteral, world: SimWorld, label_of: LabelOf) -> tuple[str, str] | None:
    """(thing, holder) labels of a ``contain`` fact between two objects of the world."""
    if isinstance(lit, RelationGoal) and lit.predicate == "contain":
        holder, thing = label_of(lit.subject), label_of(lit.object)
        if holder in world.facts.objects and thing in world.facts.objects:
            return thing, holder
    return None


def _at_rest(world: SimWorld, label: str) -> bool:
    snap = world.snapshot
    return label not in snap.attached and snap.speeds.get(label, 0.0) <= REST_SPEED


def _physics(lit: GoalLiteral, world: SimWorld, label_of: LabelOf) -> tuple[bool | None, str]:
    pair = _contained(lit, world, label_of)
    if pair is not None:
        thing, holder = pair
        inside = world.object_in(thing, holder)
        where = world.body_pose(thing)
        seen = f"{thing} {'lies' if inside else 'does not lie'} in {holder}"
        if not _at_rest(world, thing):
            speed = world.snapshot.speeds.get(thing, 0.0)
            held = thing in world.snapshot.attached
            seen += " (held by a gripper)" if held else f" (still moving, {speed:.3f} m/s)"
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
    goal: Goal,
    view: WorldView,
    world: SimWorld,
    label_of: LabelOf,
    *,
    settle: float = 0.5,
    rest_within: float = 5.0,
) -> list[FactCheck]:
    """Check every literal of ``goal`` (see the module doc): after ``settle`` simulated
    seconds, and once every object a ``contain`` fact names is at rest (at most
    ``rest_within`` simulated seconds more)."""
    things = [pair[0] for lit in goal.literals if (pair := _contained(lit, world, label_of))]
    await world.sleep(settle)  # returns at once if the world has stopped
    deadline = world.snapshot.time + rest_within
    while world.snapshot.time < deadline and world.failure is None:
        if all(_at_rest(world, t) for t in things):
            break
        await world.sleep(0.1)
    checks = []
    for lit in goal.literals:
        physics, detail = _physics(lit, world, label_of)
        checks.append(FactCheck(_fact(lit, label_of), _in_wm(lit, view), physics, detail))
    return checks
