"""Does the goal really hold? Each goal fact checked in the world model and in the physics.

The task agent's verdict rests on the world model, which the skills' post-conditions wrote. A
simulator on the mesh (:mod:`device_drivers.truth`: ``skimesh sim`` serves ``sim/truth``)
knows where things really are, and :func:`check_goal_facts` asks it:

- ``contain(C, X)`` between two objects of the simulated world: ``X`` lies in ``C`` at rest,
  not held (inside the inner footprint, between floor and rim);
- ``doorOpen(A)`` / ``heating(A)`` of a simulated appliance: its device state (door angle,
  heater);
- anything else (``heated(MealBox-1)``: the simulation has no temperatures) is a world-model
  fact only, and says so.

It first lets the world settle (``settle`` simulated seconds, then until the objects named are
at rest, within ``rest_within``), so a part still rolling into its box is judged at rest, and
one still moving or held is reported as such. Without a simulator (``truth=None``) every fact
is checked in the world model only and the result says why. The same function serves the task
agent (over the mesh, :class:`~device_drivers.truth.TruthClient`) and the one-process demo (its
in-process world, ``mujoco_sim.SimTruth``).
"""

from __future__ import annotations

from collections.abc import Callable

from device_drivers import DeviceError
from device_drivers import truth as t
from skill_agent import WorldView

from ._goals import Goal, GoalLiteral, PropertyGoal, RelationGoal
from .protocol import FactCheck, GoalCheck

__all__ = ["NO_SIMULATOR", "check_goal_facts", "fact_text"]

NO_SIMULATOR = "no simulator on the mesh: checked in the world model only"
LabelOf = Callable[[str], str]


def _labels(view: WorldView) -> LabelOf:
    def label_of(element_id: str) -> str:
        element = view.find_element(element_id)
        return element.label if element is not None and element.label else element_id

    return label_of


def _in_wm(lit: GoalLiteral, view: WorldView) -> bool:
    if isinstance(lit, RelationGoal):
        found = bool(view.query_relation(lit.subject, lit.predicate, lit.object))
        return found == lit.holds
    element = view.find_element(lit.element)
    value = element.properties.get(lit.property) if element is not None else None
    if isinstance(lit.value, bool) and value is None:
        value = False  # an unset boolean property is false (as the planner reads it)
    return (value == lit.value) == lit.holds


def fact_text(lit: GoalLiteral, label_of: LabelOf) -> str:
    """The literal with labels: ``contain(KitBox-1, Gear-1)``, ``doorOpen(Microwave-1) = false``."""
    if isinstance(lit, RelationGoal):
        neg = "" if lit.holds else "not "
        return f"{neg}{lit.predicate}({label_of(lit.subject)}, {label_of(lit.object)})"
    op = "=" if lit.holds else "!="
    value = str(lit.value).lower() if isinstance(lit.value, bool) else lit.value
    return f"{lit.property}({label_of(lit.element)}) {op} {value}"


def _contained(lit: GoalLiteral, objects: set[str], label_of: LabelOf) -> tuple[str, str] | None:
    """(thing, holder) labels of a ``contain`` fact between two objects of the world."""
    if isinstance(lit, RelationGoal) and lit.predicate == "contain":
        holder, thing = label_of(lit.subject), label_of(lit.object)
        if holder in objects and thing in objects:
            return thing, holder
    return None


class _Asker:
    """One check's questions to the simulator; remembers the latest simulated time."""

    def __init__(self, truth: t.GroundTruth, scene: t.SceneReply, label_of: LabelOf) -> None:
        self.truth, self.label_of = truth, label_of
        self.objects, self.appliances = set(scene.objects), set(scene.appliances)
        self.time = scene.time

    async def ask(self, request: t.TruthRequest) -> t.TruthReply:
        reply = await self.truth.answer(request)
        self.time = max(self.time, getattr(reply, "time", self.time))
        return reply

    async def physics(self, lit: GoalLiteral) -> tuple[bool | None, str]:
        pair = _contained(lit, self.objects, self.label_of)
        if pair is not None:
            reply = await self.ask(t.ObjectIn(thing=pair[0], holder=pair[1]))
            if not isinstance(reply, t.ObjectInReply):
                return None, f"cannot tell: the simulator answered {type(reply).__name__}"
            seen = f"{reply.thing} {'lies' if reply.inside else 'does not lie'} in {reply.holder}"
            if reply.held:
                seen += " (held by a gripper)"
            elif not reply.at_rest:
                seen += f" (still moving, {reply.speed:.3f} m/s)"
            where = reply.pose
            return reply.inside == lit.holds, (
                f"{seen} (at {where.x:.3f}, {where.y:.3f}, {where.z:.3f})"
            )
        if isinstance(lit, PropertyGoal) and lit.property in ("doorOpen", "heating"):
            label = self.label_of(lit.element)
            if label in self.appliances:
                answer = await self.ask(t.ApplianceTruth(label=label))
                if not isinstance(answer, t.ApplianceReply):
                    return None, f"cannot tell: the simulator answered {type(answer).__name__}"
                state = answer.state
                if lit.property == "doorOpen":
                    actual = state.door_open
                    text = f"door {'open' if actual else 'closed'} ({state.door_angle:.2f} rad)"
                else:
                    actual = state.heating
                    text = f"heater {'on' if actual else 'off'}"
                return (actual == lit.value) == lit.holds, text
        return None, "cannot tell: the simulation has no such fact; a world-model fact only"


async def check_goal_facts(
    goal: Goal,
    view: WorldView,
    truth: t.GroundTruth | None,
    *,
    label_of: LabelOf | None = None,
    note: str = "",
    settle: float = 0.5,
    rest_within: float = 5.0,
) -> GoalCheck:
    """Check every literal of ``goal`` in ``view`` and, with ``truth``, in the physics (see
    the module doc). ``note``: why there is no ``truth`` (default :data:`NO_SIMULATOR`). A
    simulator that fails while answering makes the facts it could not check "cannot tell"."""
    label_of = label_of or _labels(view)
    in_wm = [_in_wm(lit, view) for lit in goal.literals]
    texts = [fact_text(lit, label_of) for lit in goal.literals]
    if truth is None:
        facts = [
            FactCheck(fact=text, in_wm=held, physics=None, detail="cannot tell: no simulator")
            for text, held in zip(texts, in_wm, strict=True)
        ]
        return GoalCheck(facts=facts, note=note or NO_SIMULATOR)
    try:
        scene = await truth.answer(t.Scene())
        if not isinstance(scene, t.SceneReply):
            raise DeviceError(f"the simulator answered {type(scene).__name__} to Scene")
    except DeviceError as exc:
        return await check_goal_facts(
            goal, view, None, label_of=label_of, note=f"the simulator cannot answer: {exc}"
        )
    asker = _Asker(truth, scene, label_of)
    things = [p[0] for lit in goal.literals if (p := _contained(lit, asker.objects, label_of))]
    notes: list[str] = []
    try:
        settled = await asker.ask(t.Settle(objects=things, settle=settle, rest_within=rest_within))
        if isinstance(settled, t.SettleReply) and settled.moving:
            notes.append(f"still moving or held after settling: {', '.join(settled.moving)}")
    except DeviceError as exc:
        notes.append(f"the world did not settle: {exc}")
    facts = []
    for lit, text, held in zip(goal.literals, texts, in_wm, strict=True):
        try:
            physics, detail = await asker.physics(lit)
        except DeviceError as exc:
            physics, detail = None, f"cannot tell: {type(exc).__name__}: {exc}"
        facts.append(FactCheck(fact=text, in_wm=held, physics=physics, detail=detail))
    return GoalCheck(facts=facts, simulator=True, sim_time=asker.time, note="; ".join(notes))
