"""Why a goal cannot be reached: :func:`diagnose`, by delete-relaxed forward reachability
(the rule is in :mod:`task_agent.reachability`)."""

from __future__ import annotations

from collections import defaultdict
from collections.abc import Iterator, Mapping, Sequence

from ..domain import ActionSchema, GroundFact, PlanningTask
from ._relevance import Typing, Writers, unify
from ._replay import (
    fact_text,
    substitute,
)

__all__ = ["diagnose"]

_BUDGET = 200_000


class _Relaxed:
    """Delete-relaxed reachability over ground facts."""

    def __init__(self, task: PlanningTask) -> None:
        self.task = task
        self.facts: set[GroundFact] = set(task.init)
        self.by_pred: dict[str, set[GroundFact]] = defaultdict(set)
        for f in self.facts:
            self.by_pred[f[0]].add(f)
        self.by_type: dict[str, list[str]] = defaultdict(list)
        for obj, t in task.objects.items():
            while True:
                self.by_type[t].append(obj)
                if t not in task.types:
                    break
                t = task.types[t]
        self.work = 0
        self.writers = Writers(task)
        self.typing = Typing(task)

    def _bindings(self, schema: ActionSchema) -> Iterator[dict[str, str]]:
        """Bindings under which every positive precondition is reachable and no negative
        precondition on a static predicate is false (static facts never change)."""
        lits = [lit for lit in schema.pre if lit.positive]
        lits.sort(key=lambda lit: len(self.by_pred.get(lit.pred, ())))
        static = [
            lit for lit in schema.pre if not lit.positive and self.task.predicates[lit.pred].static
        ]
        types = {f"?{n}": t for n, t in schema.params}

        def rec(i: int, b: dict[str, str]) -> Iterator[dict[str, str]]:
            self.work += 1
            if self.work > _BUDGET:
                raise OverflowError
            if i == len(lits):
                free = [v for v in types if v not in b]
                for full in self._expand(free, types, b):
                    if not any(
                        (lit.pred, substitute(lit.args, full)) in self.facts for lit in static
                    ):
                        yield full
                return
            for fact in list(self.by_pred.get(lits[i].pred, ())):
                extended = self._match(lits[i].args, fact[1], b, types)
                if extended is not None:
                    yield from rec(i + 1, extended)

        yield from rec(0, {})

    def _match(
        self,
        args: tuple[str, ...],
        values: tuple[str, ...],
        b: dict[str, str],
        types: Mapping[str, str],
    ) -> dict[str, str] | None:
        """``b`` extended so that ``args`` (variables and constants) become ``values``."""
        out = dict(b)
        for a, v in zip(args, values, strict=True):
            if not a.startswith("?"):
                if a != v:
                    return None
            elif a in out:
                if out[a] != v:
                    return None
            elif self.typing.fits(v, types[a]):
                out[a] = v
            else:
                return None
        return out

    def _expand(
        self, free: list[str], types: Mapping[str, str], b: dict[str, str]
    ) -> Iterator[dict[str, str]]:
        if not free:
            yield b
            return
        for obj in self.by_type.get(types[free[0]], ()):
            self.work += 1
            if self.work > _BUDGET:
                raise OverflowError
            yield from self._expand(free[1:], types, {**b, free[0]: obj})

    def run(self) -> None:
        changed = True
        while changed:
            changed = False
            for schema in self.task.actions.values():
                new = {
                    (lit.pred, substitute(lit.args, b))
                    for b in self._bindings(schema)
                    for lit in schema.add
                }
                for f in new - self.facts:
                    self.facts.add(f)
                    self.by_pred[f[0]].add(f)
                    changed = True

    def reachable(self, pred: str, args: Sequence[str | None]) -> bool:
        return any(
            all(a is None or a == v for a, v in zip(args, f[1], strict=True))
            for f in self.by_pred.get(pred, ())
        )

    def explain(self, pred: str, args: tuple[str | None, ...], depth: int) -> str:
        """Why no reachable state has ``pred(args)``: each achieving action and the first of
        its preconditions never reached, ``depth`` levels down; "" if no action achieves it."""
        reasons: list[str] = []
        achievers = 0
        for schema, eff, _ in self.writers.get(pred, True, args):
            b = unify(eff, args, schema, self.typing)
            if b is None:
                continue
            achievers += 1
            for lit in schema.pre:
                found = tuple(b.get(a) if a.startswith("?") else a for a in lit.args)
                if not lit.positive or self.reachable(lit.pred, found):
                    continue
                shown = fact_text(lit.pred, [f or a for f, a in zip(found, lit.args, strict=True)])
                deeper = self.explain(lit.pred, found, depth - 1) if depth > 1 else None
                if deeper == "":
                    shown += ", which no skill's post-condition makes true"
                elif deeper:
                    shown += f" ({deeper})"
                if f"{schema.name} needs {shown}" not in reasons:
                    reasons.append(f"{schema.name} needs {shown}")
                break
        if not achievers:
            return ""
        if not reasons:
            return "the preconditions of the skills that make it true never hold together"
        return "; ".join(reasons[:3]) + ("; ..." if len(reasons) > 3 else "")


def diagnose(task: PlanningTask) -> tuple[str, list[str]]:
    """A reason a person can act on, and the goal facts that can never be reached (empty
    when every goal fact is reachable ignoring deletes: the goals conflict, or resources
    run out)."""
    relaxed = _Relaxed(task)
    try:
        relaxed.run()
    except OverflowError:
        return "the task is too large to analyse why no plan exists", []
    unreachable: list[str] = []
    reasons: list[str] = []
    for lit in task.goal:
        shown = fact_text(lit.pred, lit.args)
        if lit.positive and (lit.pred, lit.args) not in relaxed.facts:
            unreachable.append(shown)
            why = relaxed.explain(lit.pred, lit.args, 3)
            why = why or "no skill's post-condition makes it true"
            reasons.append(f"{shown} is unreachable: {why}")
        elif (
            not lit.positive
            and (lit.pred, lit.args) in task.init
            and not any(
                unify(eff, lit.args, schema, relaxed.typing)
                for schema, eff, _ in relaxed.writers.get(lit.pred, False, lit.args)
            )
        ):
            unreachable.append(f"not {shown}")
            reasons.append(f"not {shown} is unreachable: no skill's post-condition undoes it")
    if not reasons:
        return (
            "every goal fact is reachable on its own, but not together from this state "
            "(conflicting goals, or something used up on the way)",
            [],
        )
    return "; ".join(reasons), unreachable
