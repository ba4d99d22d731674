"""The action semantics of a generated domain, step by step (what a PDDL validator does).

A :class:`State` is a set of ground facts; :func:`apply` runs one :class:`GroundStep` on it and
tells which preconditions were false and what the step read and wrote (:class:`StepEffects`, the
partial order's input); :func:`replay` runs a whole plan from the initial facts and says what
went wrong, if anything (the planner re-checks a plan found on a compressed task with it). Pure.
"""

from __future__ import annotations

from collections import defaultdict
from collections.abc import Mapping, Sequence

import msgspec

from ..domain import ActionSchema, GroundFact, PlanningTask

__all__ = [
    "GroundStep",
    "Pattern",
    "State",
    "StepEffects",
    "apply",
    "binding",
    "fact_text",
    "replay",
    "substitute",
    "unmet",
    "unmet_goals",
]

Pattern = tuple[str, tuple[str | None, ...]]
"""A fact with wildcards (None)."""


class GroundStep(msgspec.Struct, frozen=True):
    """An action with its arguments (element ids, in the order of ``ActionSchema.params``)."""

    action: str
    args: tuple[str, ...]


class StepEffects(msgspec.Struct, frozen=True):
    """What one step read and wrote, in the state it ran in."""

    reads: frozenset[GroundFact]
    patterns: frozenset[Pattern]
    """Reads of "any fact like this" (derived ``empty`` and conditional-effect conditions)."""
    adds: frozenset[GroundFact]
    dels: frozenset[GroundFact]


class State:
    """A set of facts indexed by predicate and argument position."""

    def __init__(self, facts: frozenset[GroundFact] | set[GroundFact] = frozenset()) -> None:
        self.facts: set[GroundFact] = set()
        self._index: dict[tuple[str, int, str], set[GroundFact]] = defaultdict(set)
        for f in facts:
            self.add(f)

    def __contains__(self, fact: object) -> bool:
        return fact in self.facts

    def add(self, fact: GroundFact) -> None:
        if fact not in self.facts:
            self.facts.add(fact)
            for i, a in enumerate(fact[1]):
                self._index[(fact[0], i, a)].add(fact)

    def discard(self, fact: GroundFact) -> None:
        if fact in self.facts:
            self.facts.discard(fact)
            for i, a in enumerate(fact[1]):
                self._index[(fact[0], i, a)].discard(fact)

    def matching(self, pred: str, position: int, value: str) -> set[GroundFact]:
        return self._index.get((pred, position, value), set())

    def copy(self) -> State:
        new = State()
        new.facts = set(self.facts)
        new._index.update((k, set(v)) for k, v in self._index.items() if v)
        return new


def binding(schema: ActionSchema, args: Sequence[str]) -> dict[str, str]:
    """The action's variables (``?name``) bound to ``args``."""
    return {f"?{name}": a for (name, _), a in zip(schema.params, args, strict=True)}


def substitute(args: tuple[str, ...], b: Mapping[str, str]) -> tuple[str, ...]:
    """``args`` with the variables ``b`` binds replaced by their values."""
    return tuple(b.get(a, a) for a in args)


def fact_text(pred: str, args: Sequence[str | None]) -> str:
    """``pred(a, b)``, with ``?`` for a wildcard."""
    return f"{pred}({', '.join(a or '?' for a in args)})"


def unmet(task: PlanningTask, step: GroundStep, state: State) -> list[str]:
    """The preconditions of ``step`` that are false in ``state`` (the state is unchanged)."""
    schema = task.actions[step.action]
    b = binding(schema, step.args)
    failed = []
    for lit in schema.pre:
        fact = (lit.pred, substitute(lit.args, b))
        if (fact in state) != lit.positive:
            failed.append(("" if lit.positive else "not ") + fact_text(fact[0], fact[1]))
    for preds, arg, positive in schema.empty_pre:
        x = b.get(arg, arg)
        if any(state.matching(p, 0, x) for p in preds) == positive:
            failed.append(f"{'' if positive else 'not '}empty({x}, {'/'.join(preds)})")
    return failed


def apply(task: PlanningTask, step: GroundStep, state: State) -> tuple[list[str], StepEffects]:
    """Apply ``step`` to ``state`` in place; returns the preconditions that were false (the
    step is applied anyway) and what it read and wrote."""
    schema = task.actions[step.action]
    b = binding(schema, step.args)
    failed = unmet(task, step, state)
    reads = {
        (lit.pred, substitute(lit.args, b))
        for lit in schema.pre
        if not task.predicates[lit.pred].static
    }
    patterns: set[Pattern] = set()
    for preds, arg, _ in schema.empty_pre:
        x = b.get(arg, arg)
        patterns |= {(p, (x, None)) for p in preds}
    dels = {(lit.pred, substitute(lit.args, b)) for lit in schema.delete}
    for fd in schema.forall_delete:
        fixed = b.get(fd.fixed, fd.fixed)
        fixed_at = 1 - fd.free_pos
        patterns.add((fd.cond, (None, fixed) if fixed_at == 1 else (fixed, None)))
        dels |= {(fd.delete, f[1]) for f in state.matching(fd.cond, fixed_at, fixed)}
    adds = {(lit.pred, substitute(lit.args, b)) for lit in schema.add}
    for f in dels - adds:
        state.discard(f)
    for f in adds:
        state.add(f)
    effects = StepEffects(
        frozenset(reads), frozenset(patterns), frozenset(adds), frozenset(dels - adds)
    )
    return failed, effects


def unmet_goals(task: PlanningTask, state: State) -> list[str]:
    return [
        ("" if lit.positive else "not ") + fact_text(lit.pred, lit.args)
        for lit in task.goal
        if ((lit.pred, lit.args) in state) != lit.positive
    ]


def replay(task: PlanningTask, steps: Sequence[GroundStep]) -> tuple[list[StepEffects], str]:
    """Run ``steps`` from the initial facts: each step's effects, and "" if every
    precondition held and the goal holds at the end, else what went wrong."""
    state = State(task.init)
    out: list[StepEffects] = []
    problem = ""
    for i, step in enumerate(steps):
        failed, effects = apply(task, step, state)
        out.append(effects)
        if failed and not problem:
            problem = f"step {i + 1} {step.action}{step.args}: false precondition {failed[0]}"
    if not problem:
        missing = unmet_goals(task, state)
        problem = f"the goal does not hold at the end: {', '.join(missing)}" if missing else ""
    return out, problem
