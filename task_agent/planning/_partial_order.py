"""A sequential plan as a partial order the robots can run in parallel, with a schedule.

Two steps keep their plan order when swapping them could change what happens (conflict-based
deordering; every linear extension of the result is a valid plan with the same final state):

``causal``    the later step reads a fact the earlier one adds or deletes (a step "reads" its
              preconditions, negated ones included, and, as patterns, the facts an ``empty``
              precondition or a conditional delete looks at);
``threat``    the later step adds or deletes a fact the earlier one reads;
``conflict``  one adds what the other deletes;
``resource``  both belong to the same agent (an agent runs one skill at a time here), or both
              use the same piece of hardware (a robot, a device, an appliance).

Each step then starts as soon as all its predecessors have finished; the makespan is the
latest finish. A step's duration is the skill description's figure, or, given a
:class:`StepTiming` (``timing=``: :class:`task_agent.learning.StepTimer`), what that agent's
runs of the skill took so far (over the distance for a step that drives).

Allocation (``balance=True``): the planner picks an agent for each step, not a balanced one.
Greedy list scheduling then re-linearizes the steps by start time and revisits them in that
order, moving a step to another agent offering the same skill when the step is interchangeable
there (the same skill parameters, re-bound to that agent's hardware, and the whole plan still
replays from the world model's state to the goal) and the makespan shrinks; the later steps of
the same agent that use what the step leaves on its hardware (a part in its gripper) move with
it; it repeats until
no move helps. A move is only tried when the other agent's own load plus the step is below the
makespan (otherwise it cannot help); the loads and the moved step's duration come from the
same timing, so learned durations balance the work. The steps come out in that start-time
order.
"""

from __future__ import annotations

import math
from collections.abc import Iterable, Mapping, Sequence
from typing import Literal, Protocol

import msgspec

from ..domain import PlanningTask
from ..reachability import State, StepEffects, apply, replay, unmet, unmet_goals
from ._plan import Plan, PlanStep

__all__ = ["Edge", "PartialOrderPlan", "ScheduledStep", "StepTiming", "to_partial_order"]

EdgeReason = Literal["causal", "threat", "conflict", "resource"]
Key = tuple[str, ...] | tuple[str, int, str]


class StepTiming(Protocol):
    """Step durations other than the skill descriptions' (learned ones)."""

    def seconds(
        self, agent: str, skill: str, params: Mapping[str, object], default: float
    ) -> float: ...


def _timed(steps: Sequence[PlanStep], timing: StepTiming | None) -> list[PlanStep]:
    """``steps`` with ``timing``'s durations (unchanged without one)."""
    if timing is None:
        return list(steps)
    return [
        msgspec.structs.replace(s, duration=timing.seconds(s.agent, s.skill, s.params, s.duration))
        for s in steps
    ]


class Edge(msgspec.Struct, frozen=True):
    """``before`` must finish before ``after`` starts (indices into the steps)."""

    before: int
    after: int
    reason: EdgeReason
    what: str = ""
    """The fact or resource behind the ordering."""


class ScheduledStep(msgspec.Struct, frozen=True, kw_only=True):
    step: PlanStep
    start: float
    finish: float
    resources: tuple[str, ...]


class PartialOrderPlan(msgspec.Struct, frozen=True, kw_only=True):
    steps: tuple[ScheduledStep, ...]
    edges: tuple[Edge, ...]
    """The orderings left after transitive reduction."""
    makespan: float
    sequential: float
    """Estimated seconds when the same steps run one after the other."""
    moves: tuple[str, ...] = ()
    """Re-assignments made by balancing, as text."""

    def predecessors(self, index: int) -> list[int]:
        return sorted(e.before for e in self.edges if e.after == index)

    @property
    def agents(self) -> list[str]:
        return sorted({s.step.agent for s in self.steps})

    def render(self) -> str:
        """The schedule as text: a header, then one line per step in start order."""
        ratio = self.makespan / self.sequential if self.sequential else math.nan
        lines = [
            f"{len(self.steps)} steps on {len(self.agents)} agents: makespan "
            f"{self.makespan:.1f} s, sequential {self.sequential:.1f} s ({ratio:.2f}x)"
        ]
        width = max((len(s.step.agent) for s in self.steps), default=0)
        order = sorted(range(len(self.steps)), key=lambda i: (self.steps[i].start, i))
        for i in order:
            s = self.steps[i]
            args = ", ".join(f"{k}={v}" for k, v in s.step.params.items())
            after = ",".join(str(p + 1) for p in self.predecessors(i)) or "-"
            lines.append(
                f"{i + 1:4d} {s.start:7.1f} {s.finish:7.1f}  {s.step.agent:<{width}}  "
                f"{s.step.skill}({args})  after {after}"
            )
        lines += [f"moved: {m}" for m in self.moves]
        return "\n".join(lines)

    def to_dot(self) -> str:
        """The DAG in Graphviz dot (edge labels: the reason)."""
        out = ["digraph plan {", "  rankdir=LR;"]
        for i, s in enumerate(self.steps):
            label = f"{i + 1}. {s.step.agent}: {s.step.skill}\\n[{s.start:.1f}, {s.finish:.1f}]"
            out.append(f'  s{i} [shape=box, label="{label}"];')
        out += [f'  s{e.before} -> s{e.after} [label="{e.reason}"];' for e in self.edges]
        return "\n".join([*out, "}"])


# --------------------------------------------------------------------------- ordering


def _keys(facts: Iterable[tuple[str, tuple[str, ...]]]) -> dict[Key, str]:
    """Every way a pattern can match these facts: (pred,), (pred, position, arg)."""
    out: dict[Key, str] = {}
    for pred, args in facts:
        text = f"{pred}({', '.join(args)})"
        out[(pred,)] = text
        for i, a in enumerate(args):
            out[(pred, i, a)] = text
    return out


class _Access(msgspec.Struct, frozen=True):
    reads: frozenset[tuple[str, tuple[str, ...]]]
    pattern_keys: frozenset[Key]
    adds: frozenset[tuple[str, tuple[str, ...]]]
    dels: frozenset[tuple[str, tuple[str, ...]]]
    write_keys: dict[Key, str]
    resources: frozenset[str]


def _access(effects: StepEffects, resources: frozenset[str]) -> _Access:
    keys: set[Key] = set()
    for pred, args in effects.patterns:
        bound = [(i, a) for i, a in enumerate(args) if a is not None]
        keys.add((pred, *bound[0]) if bound else (pred,))
    return _Access(
        effects.reads,
        frozenset(keys),
        effects.adds,
        effects.dels,
        _keys(effects.adds | effects.dels),
        resources,
    )


def _conflict(a: _Access, b: _Access) -> tuple[EdgeReason, str] | None:
    """Why ``a`` (earlier) must stay before ``b`` (later), or None."""
    for f in (a.adds | a.dels) & b.reads:
        return "causal", f"{f[0]}({', '.join(f[1])})"
    for k in b.pattern_keys & a.write_keys.keys():
        return "causal", a.write_keys[k]
    for f in a.reads & (b.adds | b.dels):
        return "threat", f"{f[0]}({', '.join(f[1])})"
    for k in a.pattern_keys & b.write_keys.keys():
        return "threat", b.write_keys[k]
    for f in (a.adds & b.dels) | (a.dels & b.adds):
        return "conflict", f"{f[0]}({', '.join(f[1])})"
    shared = a.resources & b.resources
    if shared:
        return "resource", min(shared)
    return None


def _hardware(task: PlanningTask) -> set[str]:
    found = {v for s in task.actions.values() for v in s.bound.values()}
    found |= {a for pred, args in task.init if pred == "owns" for a in args}
    return found


def _resources(task: PlanningTask, step: PlanStep, hardware: set[str]) -> frozenset[str]:
    """What ``step`` holds: its agent, and the devices it binds but the ones its agent shares
    with others (locked per agent: they order only this agent's steps, as the agent does)."""
    action = task.actions.get(step.action)
    shared = set(action.shared) if action is not None else set()
    devices = (v for v in step.params.values() if v in hardware and v not in shared)
    return frozenset({f"agent {step.agent}", *devices})


def _build(
    task: PlanningTask, steps: Sequence[PlanStep], effects: Sequence[StepEffects]
) -> tuple[list[float], list[float], list[Edge], list[frozenset[str]]]:
    hardware = _hardware(task)
    resources = [_resources(task, s, hardware) for s in steps]
    access = [_access(e, r) for e, r in zip(effects, resources, strict=True)]
    n = len(steps)
    edges: list[Edge] = []
    start, finish = [0.0] * n, [0.0] * n
    below = [0] * n  # bit i set: step i is a (transitive) predecessor
    for j in range(n):
        direct: list[Edge] = []
        for i in range(j - 1, -1, -1):
            found = _conflict(access[i], access[j])
            if found is not None:
                direct.append(Edge(i, j, found[0], found[1]))
        for e in direct:
            start[j] = max(start[j], finish[e.before])
            below[j] |= below[e.before] | (1 << e.before)
        implied = 0
        for e in sorted(direct, key=lambda e: -e.before):  # latest first
            if not implied >> e.before & 1:
                edges.append(e)
            implied |= below[e.before]
        finish[j] = start[j] + steps[j].duration
    return start, finish, edges, resources


def _schedule(
    task: PlanningTask, steps: Sequence[PlanStep], moves: Sequence[str] = ()
) -> PartialOrderPlan:
    effects, _ = replay(task, [s.ground for s in steps])
    start, finish, edges, resources = _build(task, steps, effects)
    return PartialOrderPlan(
        steps=tuple(
            ScheduledStep(step=s, start=b, finish=f, resources=tuple(sorted(r)))
            for s, b, f, r in zip(steps, start, finish, resources, strict=True)
        ),
        edges=tuple(sorted(edges, key=lambda e: (e.after, e.before))),
        makespan=max(finish, default=0.0),
        sequential=sum(s.duration for s in steps),
        moves=tuple(moves),
    )


# --------------------------------------------------------------------------- allocation


def _alternatives(task: PlanningTask, step: PlanStep, timing: StepTiming | None) -> list[PlanStep]:
    """The step re-bound to each other agent offering the same skill (timed by ``timing``)."""
    out = []
    for schema in task.actions.values():
        if schema.skill != step.skill or schema.agent == step.agent:
            continue
        args = tuple(step.params.get(name, "") for name, _ in schema.params)
        if "" in args or any(a not in task.objects for a in args):
            continue
        params = dict(schema.bound)
        params.update((name, a) for (name, _), a in zip(schema.params, args, strict=True))
        out.append(
            msgspec.structs.replace(
                step,
                action=schema.name,
                agent=schema.agent,
                skill=schema.skill,
                args=args,
                params=params,
                duration=schema.duration,
            )
        )
    return _timed(out, timing)


def _states(task: PlanningTask, steps: Sequence[PlanStep]) -> list[State]:
    """The state before each step."""
    state = State(task.init)
    out = []
    for s in steps:
        out.append(state.copy())
        apply(task, s.ground, state)
    return out


def _valid_from(task: PlanningTask, state: State, steps: Sequence[PlanStep]) -> bool:
    """Whether ``steps`` run from ``state`` (changed in place) and reach the goal."""
    for s in steps:
        failed, _ = apply(task, s.ground, state)
        if failed:
            return False
    return not unmet_goals(task, state)


def _moved(
    task: PlanningTask,
    steps: Sequence[PlanStep],
    effects: Sequence[StepEffects],
    k: int,
    alt: PlanStep,
    timing: StepTiming | None,
) -> list[PlanStep] | None:
    """``steps`` with step ``k`` replaced by ``alt`` and, with it, the later steps of the
    same agent that use what step ``k`` left on that agent's hardware (the part a pick put in
    its gripper, which only that gripper can place); None if one of them cannot move."""
    out = list(steps)
    out[k] = alt
    agent = steps[k].agent
    schema = task.actions.get(steps[k].action)
    own = set(schema.bound.values()) if schema is not None else set()
    held = {f for f in effects[k].adds if own & set(f[1])}
    for j in range(k + 1, len(steps)):
        if not held or steps[j].agent != agent or not effects[j].reads & held:
            continue
        rebound = [a for a in _alternatives(task, steps[j], timing) if a.agent == alt.agent]
        if not rebound:
            return None
        out[j] = rebound[0]
        held |= {f for f in effects[j].adds if own & set(f[1])}
    return out


def _balance(
    task: PlanningTask, steps: list[PlanStep], rounds: int, timing: StepTiming | None
) -> PartialOrderPlan:
    best = _schedule(task, steps)
    moves: list[str] = []
    for _ in range(rounds):
        # Steps in start order: a linear extension of the partial order (an edge i -> j has
        # i < j and start_i <= start_j), so still a valid plan, and each step now sees the
        # state it will meet when the robots work in parallel.
        order = sorted(range(len(steps)), key=lambda i: (best.steps[i].start, i))
        steps = [steps[i] for i in order]
        best = _schedule(task, steps)
        load: dict[str, float] = {}
        for s in steps:
            load[s.agent] = load.get(s.agent, 0.0) + s.duration
        states: list[State] | None = None
        effects: list[StepEffects] | None = None
        moved = False
        for k in range(len(steps)):
            candidates = []
            for alt in _alternatives(task, steps[k], timing):
                # the other agent's work alone would last at least this long
                if load.get(alt.agent, 0.0) + alt.duration >= best.makespan - 1e-9:
                    continue
                states = states or _states(task, steps)
                if unmet(task, alt.ground, states[k]):
                    continue
                effects = effects or replay(task, [s.ground for s in steps])[0]
                trial = _moved(task, steps, effects, k, alt, timing)
                if trial is None or not _valid_from(task, states[k].copy(), trial[k:]):
                    continue
                schedule = _schedule(task, trial)
                if schedule.makespan < best.makespan - 1e-9:
                    candidates.append((schedule.makespan, alt.agent, trial, schedule))
            if candidates:
                _, _, steps, best = min(candidates, key=lambda c: (c[0], c[1]))
                moves.append(f"step {k + 1} {steps[k].skill}: {best.steps[k].step.agent}")
                moved = True
                break
        if not moved:
            break
    return _schedule(task, steps, moves)


def to_partial_order(
    plan: Plan, *, balance: bool = True, rounds: int = 64, timing: StepTiming | None = None
) -> PartialOrderPlan:
    """The plan's partial order and schedule (see the module doc). ``rounds`` bounds the
    number of re-assignments balancing makes; ``timing`` gives the step durations (default:
    the skill descriptions')."""
    steps = _timed(plan.steps, timing)
    if balance and len({s.agent for s in plan.task.actions.values()}) > 1:
        result = _balance(plan.task, steps, rounds, timing)
    else:
        result = _schedule(plan.task, steps)
    renumbered = tuple(
        msgspec.structs.replace(s, step=msgspec.structs.replace(s.step, index=i))
        for i, s in enumerate(result.steps)
    )
    return msgspec.structs.replace(result, steps=renumbered)
