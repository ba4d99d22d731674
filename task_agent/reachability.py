"""Analyses of a :class:`~task_agent.domain.PlanningTask` that need no planner (pure).

``State`` / :func:`apply` / :func:`replay`
    The action semantics of the generated domain, step by step (what a PDDL validator does):
    the partial order reads each step's ground reads and writes from here, and a plan found
    on a compressed task is re-checked on the full one.
:func:`relevant_objects`
    Problem compression: a backward relevance closure from the goal over the actions'
    effects and preconditions, lifted (unbound parameters are wildcards). Objects not named by
    a relevant pattern nor by an initial fact matching one are left out of the task given to
    the engine. A plan for the smaller task is replayed on the full one; if that fails, or the
    smaller task has no plan, the planner solves the full task.
:func:`diagnose`
    Why a goal cannot be reached: delete-relaxed forward reachability from the initial facts,
    then, for each goal fact never reached, the achieving actions and their unreachable
    preconditions, two levels deep.
"""

from __future__ import annotations

from collections import defaultdict, deque
from collections.abc import Iterator, Mapping, Sequence

import msgspec

from .domain import ROOT, ActionSchema, Fact, ForallDelete, PlanningTask

__all__ = [
    "GroundStep",
    "State",
    "StepEffects",
    "Typing",
    "apply",
    "diagnose",
    "relevant_objects",
    "replay",
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

    reads: frozenset[Fact]
    patterns: frozenset[Pattern]
    """Reads of "any fact like this" (derived ``empty`` and conditional-effect conditions)."""
    adds: frozenset[Fact]
    dels: frozenset[Fact]


class State:
    """A set of facts indexed by predicate and argument position."""

    def __init__(self, facts: frozenset[Fact] | set[Fact] = frozenset()) -> None:
        self.facts: set[Fact] = set()
        self._index: dict[tuple[str, int, str], set[Fact]] = defaultdict(set)
        for f in facts:
            self.add(f)

    def __contains__(self, fact: object) -> bool:
        return fact in self.facts

    def add(self, fact: Fact) -> None:
        if fact not in self.facts:
            self.facts.add(fact)
            for i, a in enumerate(fact[1]):
                self._index[(fact[0], i, a)].add(fact)

    def discard(self, fact: Fact) -> None:
        if fact in self.facts:
            self.facts.discard(fact)
            for i, a in enumerate(fact[1]):
                self._index[(fact[0], i, a)].discard(fact)

    def matching(self, pred: str, position: int, value: str) -> set[Fact]:
        return self._index.get((pred, position, value), set())

    def copy(self) -> State:
        new = State()
        new.facts = set(self.facts)
        new._index.update((k, set(v)) for k, v in self._index.items() if v)
        return new


def binding(schema: ActionSchema, args: Sequence[str]) -> dict[str, str]:
    return {f"?{name}": a for (name, _), a in zip(schema.params, args, strict=True)}


def _sub(args: tuple[str, ...], b: Mapping[str, str]) -> tuple[str, ...]:
    return tuple(b.get(a, a) for a in args)


def _show(pred: str, args: Sequence[str | None]) -> str:
    return f"{pred}({', '.join(a or '?' for a in args)})"


def unmet(task: PlanningTask, step: GroundStep, state: State) -> list[str]:
    """The preconditions of ``step`` that are false in ``state`` (the state is unchanged)."""
    schema = task.actions[step.action]
    b = binding(schema, step.args)
    failed = []
    for lit in schema.pre:
        fact = (lit.pred, _sub(lit.args, b))
        if (fact in state) != lit.positive:
            failed.append(("" if lit.positive else "not ") + _show(fact[0], fact[1]))
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
        (lit.pred, _sub(lit.args, b)) for lit in schema.pre if not task.predicates[lit.pred].static
    }
    patterns: set[Pattern] = set()
    for preds, arg, _ in schema.empty_pre:
        x = b.get(arg, arg)
        patterns |= {(p, (x, None)) for p in preds}
    dels = {(lit.pred, _sub(lit.args, b)) for lit in schema.delete}
    for fd in schema.forall_delete:
        fixed = b.get(fd.fixed, fd.fixed)
        fixed_at = 1 - fd.free_pos
        patterns.add((fd.cond, (None, fixed) if fixed_at == 1 else (fixed, None)))
        dels |= {(fd.delete, f[1]) for f in state.matching(fd.cond, fixed_at, fixed)}
    adds = {(lit.pred, _sub(lit.args, b)) for lit in schema.add}
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
        ("" if lit.positive else "not ") + _show(lit.pred, lit.args)
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


# --------------------------------------------------------------------------- compression

_FREE = "\x00w"  # the quantified variable of a conditional delete
Signed = tuple[str, tuple[str | None, ...], bool]
_Writer = tuple[ActionSchema, tuple[str, ...], ForallDelete | None]


class _Writers:
    """The actions' effects that make facts hold with a sign, found by (predicate, sign) and
    by the effect's first argument when it is an element id (most are: agents' hardware)."""

    def __init__(self, task: PlanningTask) -> None:
        self._any: dict[tuple[str, bool], list[_Writer]] = defaultdict(list)
        self._first: dict[tuple[str, bool, str], list[_Writer]] = defaultdict(list)
        for schema in task.actions.values():
            for lit in schema.add:
                self._put(lit.pred, True, (schema, lit.args, None))
            for lit in schema.delete:
                self._put(lit.pred, False, (schema, lit.args, None))
            for fd in schema.forall_delete:
                args = (_FREE, fd.fixed) if fd.free_pos == 0 else (fd.fixed, _FREE)
                self._put(fd.delete, False, (schema, args, fd))

    def _put(self, pred: str, sign: bool, writer: _Writer) -> None:
        first = writer[1][0] if writer[1] else "?"
        if first[0] == "?" or first == _FREE:
            self._any[(pred, sign)].append(writer)
        else:
            self._first[(pred, sign, first)].append(writer)

    def get(self, pred: str, sign: bool, args: tuple[str | None, ...]) -> list[_Writer]:
        """Writers whose effect may unify with ``pred(args)``."""
        found = self._any.get((pred, sign), [])
        if args and args[0] is not None:
            return found + self._first.get((pred, sign, args[0]), [])
        mine = [w for (p, s, _), ws in self._first.items() if (p, s) == (pred, sign) for w in ws]
        return found + mine


class Typing:
    """Which objects fit which types, memoized; the variables' types per action."""

    def __init__(self, task: PlanningTask) -> None:
        self.task = task
        self.variables = {s.name: {f"?{n}": t for n, t in s.params} for s in task.actions.values()}
        self._fits: dict[tuple[str, str], bool] = {}

    def fits(self, obj: str, wanted: str) -> bool:
        key = (obj, wanted)
        found = self._fits.get(key)
        if found is None:
            t: str | None = self.task.objects.get(obj)
            found = wanted == ROOT
            while t is not None and not found:
                found = t == wanted
                t = self.task.types.get(t)
            self._fits[key] = found
        return found


def _unify(
    eff: tuple[str, ...],
    pattern: tuple[str | None, ...],
    schema: ActionSchema,
    typing: Typing,
) -> dict[str, str | None] | None:
    """Bind the effect's variables to the pattern's objects, of the variables' types; None
    if they do not match."""
    b: dict[str, str | None] = {}
    types = typing.variables[schema.name]
    for e, p in zip(eff, pattern, strict=True):
        if e == _FREE:
            b[e] = p
        elif e[0] == "?":
            prev = b.get(e)
            if p is None:
                b.setdefault(e, None)
            elif prev is None:
                if not typing.fits(p, types[e]):
                    return None
                b[e] = p
            elif prev != p:
                return None
        elif p is not None and e != p:
            return None
    return b


def _reads(
    schema: ActionSchema, task: PlanningTask, b: Mapping[str, str | None], fd: ForallDelete | None
) -> list[Signed]:
    """What the action needs, as signed patterns, when ``b`` binds some of its variables."""

    def sub(a: str) -> str | None:
        return b.get(a) if a.startswith("?") else a

    out: list[Signed] = [
        (lit.pred, tuple(sub(a) for a in lit.args), lit.positive)
        for lit in schema.pre
        if not task.predicates[lit.pred].static
    ]
    for preds, arg, positive in schema.empty_pre:
        out += [(p, (sub(arg), None), not positive) for p in preds]
    if fd is not None:
        x, w = sub(fd.fixed), b.get(_FREE)
        out.append((fd.cond, (w, x) if fd.free_pos == 0 else (x, w), True))
    return out


def _subsumed(pattern: Signed, seen: set[Signed]) -> bool:
    """``pattern`` or a pattern more general than it is in ``seen``."""
    pred, args, sign = pattern
    if len(args) == 2:
        a, c = args
        return any((pred, g, sign) in seen for g in ((a, c), (None, c), (a, None), (None, None)))
    for mask in range(1 << len(args)):
        general = tuple(None if mask >> i & 1 else a for i, a in enumerate(args))
        if (pred, general, sign) in seen:
            return True
    return False


def relevant_objects(task: PlanningTask) -> set[str]:
    """The objects the goal can touch (see the module doc).

    Backward from the goal, delete-relaxed: a needed positive fact (and a negative goal
    fact) makes the actions that achieve it relevant, and their preconditions needed in turn;
    a needed negative fact is not chased further, but the initial facts it matches keep their
    objects (a gripper's current content matters to an "empty gripper" precondition). Kept:
    every object named by a needed pattern or by an initial fact matching one, the goal's
    elements and the actions' constants."""
    writers = _Writers(task)
    typing = Typing(task)
    seen: set[Signed] = set()
    todo: deque[Signed] = deque()
    expanded: set[tuple[str, tuple[tuple[str, str | None], ...], ForallDelete | None]] = set()

    def push(p: Signed, chase: bool) -> None:
        if not _subsumed(p, seen):
            seen.add(p)
            if chase:
                todo.append(p)

    for lit in task.goal:
        push((lit.pred, lit.args, lit.positive), True)
    while todo:
        pred, args, sign = todo.popleft()
        for schema, eff, fd in writers.get(pred, sign, args):
            b = _unify(eff, args, schema, typing)
            if b is None:
                continue
            key = (schema.name, tuple(sorted(b.items(), key=lambda kv: kv[0])), fd)
            if key not in expanded:  # the same action instance, reached another way
                expanded.add(key)
                for p in _reads(schema, task, b, fd):
                    push(p, p[2])
    keep = {a for _, args, _ in seen for a in args if a is not None}
    init = State(task.init)
    for pred, args, _ in seen:
        bound = [(i, a) for i, a in enumerate(args) if a is not None]
        found = init.matching(pred, *bound[0]) if bound else init.facts
        for f in found:
            if f[0] == pred and all(f[1][i] == a for i, a in bound[1:]):
                keep.update(f[1])
    for schema in task.actions.values():
        keep |= set(schema.bound.values())
        keep |= {a for lit in schema.pre for a in lit.args if not a.startswith("?")}
    return keep & set(task.objects)


# --------------------------------------------------------------------------- diagnosis

_BUDGET = 200_000


class _Relaxed:
    """Delete-relaxed reachability over ground facts."""

    def __init__(self, task: PlanningTask) -> None:
        self.task = task
        self.facts: set[Fact] = set(task.init)
        self.by_pred: dict[str, set[Fact]] = defaultdict(set)
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
        self.writers = _Writers(task)
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
                    if not any((lit.pred, _sub(lit.args, full)) in self.facts for lit in static):
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
                    (lit.pred, _sub(lit.args, b))
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
            b = _unify(eff, args, schema, self.typing)
            if b is None:
                continue
            achievers += 1
            for lit in schema.pre:
                found = tuple(b.get(a) if a.startswith("?") else a for a in lit.args)
                if not lit.positive or self.reachable(lit.pred, found):
                    continue
                shown = _show(lit.pred, [f or a for f, a in zip(found, lit.args, strict=True)])
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
        shown = _show(lit.pred, lit.args)
        if lit.positive and (lit.pred, lit.args) not in relaxed.facts:
            unreachable.append(shown)
            why = relaxed.explain(lit.pred, lit.args, 3)
            why = why or "no skill's post-condition makes it true"
            reasons.append(f"{shown} is unreachable: {why}")
        elif (
            not lit.positive
            and (lit.pred, lit.args) in task.init
            and not any(
                _unify(eff, lit.args, schema, relaxed.typing)
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
