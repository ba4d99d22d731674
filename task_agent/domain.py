"""A planning task from the discovered agents' skill descriptions and the current world model.

Pure data, no planner imports: :mod:`task_agent.planner` turns a :class:`PlanningTask` into a
unified-planning problem (and PDDL). The mapping:

**Actions.** One per (available agent, skill): ``pick__robot1``, ``pick__robot2``, so skills of
the same name on two robots never collide and the planner chooses who acts. Hardware
parameters are bound to the agent's own machine (its robot and the devices reached through
``hasA``): one fitting device becomes a constant of the action; several stay a parameter
restricted by the static fact ``owns(robot, device)``; none leaves the skill out (in
``skipped``, with the reason). Other element parameters that appear in a symbolic condition
become action parameters typed by their class; the rest are left to the agent's inference at
run time. A skill needing a non-element value without a default is left out.

**Conditions.** ``skill_agent.conditions.symbolic`` gives each condition's atoms over
parameter names. Pre- and hold-conditions become preconditions, post-conditions effects
(positive atoms add, negative atoms delete). A condition without a symbolic face (numeric
comparisons, ``full``, unregistered custom conditions) is run-time only: the planner ignores
it and the action records it in ``runtime_only``. Effects also carry what the world model does
implicitly:

- a spatial relation ``contain(g, x)`` re-parents ``x``: every modeled spatial fact
  ``r(?w, x)`` is deleted (``forall ?w: when r(?w, x) then not r(?w, x)``) before the new one
  is added (PDDL applies adds after deletes, so ``contain(g, x)`` stays if it held);
- a relation fact implies its modeled super-properties (``contain`` -> ``spatialRelation``);
  deleting one deletes its sub-properties too (as an abstract unset does);
- ``q=v(x)`` deletes every other modeled value ``q=w(x)`` (a property has one value) and adds
  ``has_q(x)``;
- ``empty_p(x)`` is derived, not stored: as a precondition it is ``not exists ?w: p(x, ?w)``
  (over ``p`` and its sub-properties); as an effect it deletes every ``p(x, ?w)``; a negated
  ``empty`` effect is implied by others and ignored;
- ``is_C(x)`` and ``owns`` are static facts computed from the ontology and registrations.

**Types.** The ontology classes of the action parameters form the type tree (each class under
its nearest relevant superclass, the root is ``thing``); objects are the world-model elements
of those classes, those in facts of modeled relations, the goal's elements and the agents'
hardware. A class the tree cannot express (an object belongs to two relevant classes on
different branches) types its parameters as ``thing`` plus a static ``is_C`` precondition.
"""

from __future__ import annotations

import re
from collections.abc import Iterable, Sequence
from typing import Literal, NamedTuple

import msgspec

from skill_agent.conditions import Atom, ConditionRegistry, describe, symbolic
from skill_agent.protocol import Condition, SkillDescription
from skill_agent.skill import WorldView
from wm_store.ontology import Ontology
from wm_store.protocol import Value

from .discovery_model import AgentInfo
from .errors import DomainError
from .goals import Goal, literal_atom

__all__ = [
    "ROOT",
    "ActionSchema",
    "Fact",
    "ForallDelete",
    "Lit",
    "PlanningTask",
    "Predicate",
    "build_task",
    "value_text",
]

ROOT = "thing"
Fact = tuple[str, tuple[str, ...]]
"""A ground fact: predicate (atom name) and element ids."""
PredicateKind = Literal["relation", "value", "has", "type", "owns", "opaque"]


class Lit(NamedTuple):
    """An atom over variables (``?name``) and element ids, with its sign."""

    pred: str
    args: tuple[str, ...]
    positive: bool = True


class ForallDelete(NamedTuple):
    """``forall ?w: when cond(args) then not delete(args)``, with ``?w`` at ``free_pos`` of the
    two arguments and ``fixed`` (a variable or an element id) at the other."""

    cond: str
    delete: str
    fixed: str
    free_pos: int


class Predicate(msgspec.Struct, frozen=True):
    name: str
    kind: PredicateKind
    arity: int
    pddl: str
    static: bool = False


class ActionSchema(msgspec.Struct, frozen=True, kw_only=True):
    """One skill of one agent as a planning action. Variables are named after the skill's
    parameters; ``bound`` holds the parameters fixed to this agent's hardware."""

    name: str
    agent: str
    skill: str
    family: str
    duration: float
    params: tuple[tuple[str, str], ...]
    """(parameter name, type) of the action's variables, in order."""
    bound: dict[str, str]
    pre: tuple[Lit, ...] = ()
    empty_pre: tuple[tuple[tuple[str, ...], str, bool], ...] = ()
    """(relations, argument, positive): ``positive`` means no ``r(arg, ?w)`` for any r."""
    add: tuple[Lit, ...] = ()
    delete: tuple[Lit, ...] = ()
    forall_delete: tuple[ForallDelete, ...] = ()
    runtime_only: tuple[str, ...] = ()


class PlanningTask(msgspec.Struct, frozen=True, kw_only=True):
    name: str
    types: dict[str, str]
    """PDDL type -> parent type (``ROOT`` at the top)."""
    objects: dict[str, str]
    """Element id -> PDDL type."""
    predicates: dict[str, Predicate]
    init: frozenset[Fact]
    goal: tuple[Lit, ...]
    actions: dict[str, ActionSchema]
    skipped: tuple[str, ...] = ()
    """Skills left out of the domain, with the reason."""

    def restrict(self, keep: Iterable[str]) -> PlanningTask:
        """The same task over the objects in ``keep`` only (facts naming others dropped)."""
        objects = {o: t for o, t in self.objects.items() if o in set(keep)}
        init = frozenset(f for f in self.init if all(a in objects for a in f[1]))
        return msgspec.structs.replace(self, objects=objects, init=init)


def value_text(value: Value) -> str | None:
    """A property value as atoms name it (``true``, ``3``, ``abc``); None if not symbolic."""
    if isinstance(value, bool):
        return "true" if value else "false"
    if isinstance(value, int | str):
        return str(value)
    return None


# --------------------------------------------------------------------------- predicates


class _Names:
    """Atom names -> predicate kinds, and PDDL-safe unique names."""

    def __init__(self, ontology: Ontology) -> None:
        self.ontology = ontology
        self.predicates: dict[str, Predicate] = {}
        self._taken: set[str] = set()

    def kind(self, pred: str) -> tuple[PredicateKind | Literal["empty"], str]:
        """The kind of an atom name and its subject (relation, property or class name)."""
        onto = self.ontology
        if pred in onto.relations:
            return "relation", pred
        if "=" in pred and pred.split("=", 1)[0] in onto.data_properties:
            return "value", pred.split("=", 1)[0]
        for prefix, kind, known in (
            ("has_", "has", onto.data_properties),
            ("is_", "type", onto.classes),
            ("empty_", "empty", onto.relations),
        ):
            if pred.startswith(prefix) and pred[len(prefix) :] in known:
                return kind, pred[len(prefix) :]  # type: ignore[return-value]
        return "opaque", pred

    def declare(self, pred: str, kind: PredicateKind, arity: int) -> Predicate:
        found = self.predicates.get(pred)
        if found is not None:
            return found
        base = re.sub(r"[^A-Za-z0-9_]", "_", pred.replace("=", "_eq_")) or "p"
        base = base if base[0].isalpha() else f"p_{base}"
        pddl, n = base, 1
        while pddl.lower() in self._taken:
            n += 1
            pddl = f"{base}_{n}"
        self._taken.add(pddl.lower())
        found = Predicate(pred, kind, arity, pddl, static=kind in ("type", "owns"))
        self.predicates[pred] = found
        return found


# --------------------------------------------------------------------------- skills


class _Draft(NamedTuple):
    """A skill of an agent with its atoms, before predicates are known."""

    agent: AgentInfo
    desc: SkillDescription
    variables: dict[str, str]
    """Parameter name -> ontology class (the action's variables)."""
    bound: dict[str, str]
    owned: tuple[str, ...]
    """Variables restricted to the agent's hardware (several fitting devices)."""
    pre: list[Atom]
    post: list[Atom]
    runtime_only: list[str]


def _atoms(
    conds: Sequence[Condition], registry: ConditionRegistry | None, where: str, out: list[str]
) -> list[Atom]:
    atoms: list[Atom] = []
    for cond in conds:
        found = symbolic(cond, registry=registry)
        if found is None:
            out.append(f"{where} {describe(cond)}")
        else:
            atoms += found
    return atoms


def _draft(
    agent: AgentInfo, desc: SkillDescription, view: WorldView, registry: ConditionRegistry | None
) -> _Draft | str:
    onto = view.ontology
    runtime: list[str] = []
    pre = _atoms([*desc.pre, *desc.hold], registry, "pre", runtime)
    post = _atoms(desc.post, registry, "post", runtime)
    used = {a for atom in (*pre, *post) for a in atom.args}
    variables: dict[str, str] = {}
    bound: dict[str, str] = {}
    owned: list[str] = []
    for spec in desc.parameters:
        if spec.type not in onto.classes:
            if spec.name in used:
                return f"parameter '{spec.name}' is a {spec.type} value, not an element"
            if spec.default is None and not spec.optional and spec.kind == "online":
                return (
                    f"needs a {spec.type} value for '{spec.name}', which the planner cannot choose"
                )
            continue
        if spec.kind == "hardware":
            mine = [h for h in agent.hardware if _is(view, h, spec.type)]
            if not mine and spec.optional and spec.name not in used:
                continue
            if not mine:
                return (
                    f"agent '{agent.name}' has no {spec.type} for hardware parameter '{spec.name}'"
                )
            if len(mine) == 1:
                bound[spec.name] = mine[0]
            elif spec.name in used:
                variables[spec.name] = spec.type
                owned.append(spec.name)
        elif spec.name in used:
            variables[spec.name] = spec.type
    known = set(variables) | set(bound)
    keep_pre = [a for a in pre if set(a.args) <= known]
    keep_post = [a for a in post if set(a.args) <= known]
    for atom in (a for a in (*pre, *post) if not set(a.args) <= known):
        runtime.append(f"{atom.predicate}{atom.args} (names a non-element parameter)")
    if not keep_post:
        return "no symbolic post-condition: the planner cannot use it"
    return _Draft(agent, desc, variables, bound, tuple(owned), keep_pre, keep_post, runtime)


def _is(view: WorldView, element_id: str, cls: str) -> bool:
    element = view.find_element(element_id)
    return element is not None and view.ontology.is_a(element.type, cls)


# --------------------------------------------------------------------------- the builder


class _Builder:
    def __init__(self, view: WorldView, drafts: list[_Draft], goal_atoms: list[Atom]) -> None:
        self.view, self.onto = view, view.ontology
        self.drafts, self.goal_atoms = drafts, goal_atoms
        self.names = _Names(self.onto)
        self.relations: set[str] = set()
        self.values: dict[str, set[str]] = {}
        self.has: set[str] = set()
        self.classes: set[str] = set()
        self.tree: dict[str, str] = {}
        self.objects: dict[str, str] = {}
        self.conflicts: set[str] = set()

    def predicates(self) -> None:
        atoms = [*self.goal_atoms, *(a for d in self.drafts for a in (*d.pre, *d.post))]
        opaque: dict[str, int] = {}
        for atom in atoms:
            kind, subject = self.names.kind(atom.predicate)
            if kind == "relation":
                self.relations.add(subject)
            elif kind == "empty":
                self.relations |= self.onto.subproperties(subject)
            elif kind == "value":
                self.values.setdefault(subject, set()).add(atom.predicate)
            elif kind == "has":
                self.has.add(subject)
            elif kind == "type":
                self.classes.add(subject)
            elif opaque.setdefault(atom.predicate, len(atom.args)) != len(atom.args):
                raise DomainError(f"condition atom '{atom.predicate}' is used with two arities")
        for r in sorted(self.relations):
            self.names.declare(r, "relation", 2)
        for preds in self.values.values():
            for p in sorted(preds):
                self.names.declare(p, "value", 1)
        for q in sorted(self.has):
            self.names.declare(f"has_{q}", "has", 1)
        for c in sorted(self.classes):
            self.names.declare(f"is_{c}", "type", 1)
        for p, n in sorted(opaque.items()):
            self.names.declare(p, "opaque", n)
        if any(d.owned for d in self.drafts):
            self.names.declare("owns", "owns", 2)

    def types(self, extra: Iterable[str]) -> None:
        param_classes = {c for d in self.drafts for c in d.variables.values()}
        for c in param_classes:
            up = self.onto.superclasses(c)[1:]
            self.tree[c] = next((a for a in up if a in param_classes), ROOT)
        ids: set[str] = set(extra)
        for c in param_classes:
            ids |= {e.id for e in self.view.resolve_element(type=c)}
        for r in self.relations:
            for rel in self.view.query_relation(predicate=r):
                ids |= {rel.subject, rel.object}
        for element_id in ids:
            element = self.view.find_element(element_id)
            if element is None:
                continue
            relevant = [a for a in self.onto.superclasses(element.type) if a in self.tree]
            # the type whose chain covers most of the relevant classes (then the nearest)
            chosen = max(
                relevant,
                key=lambda c: (len(set(self._chain(c)) & set(relevant)), -relevant.index(c)),
                default=ROOT,
            )
            self.objects[element_id] = chosen
            self.conflicts |= set(relevant) - set(self._chain(chosen))
        for c in sorted(self.conflicts):
            self.names.declare(f"is_{c}", "type", 1)
            self.classes.add(c)

    def _chain(self, t: str) -> list[str]:
        out = []
        while t != ROOT:
            out.append(t)
            t = self.tree[t]
        return out

    def init(self) -> set[Fact]:
        facts: set[Fact] = set()
        for r in self.relations:
            for rel in self.view.query_relation(predicate=r):
                if rel.subject in self.objects and rel.object in self.objects:
                    facts.add((r, (rel.subject, rel.object)))
        for element_id in self.objects:
            element = self.view.get_element(element_id)
            for q, preds in self.values.items():
                text = value_text(element.properties.get(q))
                if text is not None and f"{q}={text}" in preds:
                    facts.add((f"{q}={text}", (element_id,)))
            facts |= {(f"has_{q}", (element_id,)) for q in self.has if q in element.properties}
            for c in self.classes:
                if self.onto.is_a(element.type, c):
                    facts.add((f"is_{c}", (element_id,)))
        for d in self.drafts:
            for var in d.owned:
                cls = d.variables[var]
                for h in d.agent.hardware:
                    if d.agent.robot and h in self.objects and _is(self.view, h, cls):
                        facts.add(("owns", (d.agent.robot, h)))
        return facts

    # ------------------------------------------------------------------ actions

    def _supers(self, r: str) -> list[str]:
        return sorted((self.onto.superproperties(r) & self.relations) - {r})

    def _subs(self, r: str) -> list[str]:
        return sorted(self.onto.subproperties(r) & self.relations)

    def _spatial(self) -> list[str]:
        return sorted(r for r in self.relations if self.onto.relation(r).spatial)

    def _class(self, d: _Draft, arg: str) -> str:
        if arg.startswith("?"):
            return d.variables[arg[1:]]
        element = self.view.find_element(arg)
        return element.type if element is not None else ROOT

    def action(self, d: _Draft, name: str) -> ActionSchema:
        def arg(p: str) -> str:
            return d.bound.get(p) or f"?{p}"

        params: list[tuple[str, str]] = []
        pre: dict[Lit, None] = {}
        for var, cls in d.variables.items():
            if cls in self.conflicts:
                params.append((var, ROOT))
                pre[Lit(f"is_{cls}", (f"?{var}",))] = None
            else:
                params.append((var, cls))
        for var in d.owned:
            pre[Lit("owns", (d.agent.robot or "", f"?{var}"))] = None
        empty_pre: list[tuple[tuple[str, ...], str, bool]] = []
        for atom in d.pre:
            kind, subject = self.names.kind(atom.predicate)
            args = tuple(arg(a) for a in atom.args)
            if kind == "empty":
                empty_pre.append((tuple(self._subs(subject)), args[0], atom.positive))
            else:
                pre[Lit(atom.predicate, args, atom.positive)] = None
        add: dict[Lit, None] = {}
        delete: dict[Lit, None] = {}
        forall: dict[ForallDelete, None] = {}
        spatial = self._spatial()
        held = [lit for lit in pre if lit.positive and lit.pred in spatial]
        for atom in d.post:
            kind, subject = self.names.kind(atom.predicate)
            args = tuple(arg(a) for a in atom.args)
            if kind == "relation" and atom.positive:
                if self.onto.relation(subject).spatial:
                    # The tree has one spatial parent per element: when a precondition names
                    # it, delete that fact; otherwise whichever parent there is.
                    parents = {lit.args[0] for lit in held if lit.args[1] == args[1]}
                    for r in spatial:
                        for parent in parents:
                            delete[Lit(r, (parent, args[1]), False)] = None
                        if not parents:
                            forall[ForallDelete(r, r, args[1], 0)] = None
                for r in (subject, *self._supers(subject)):
                    add[Lit(r, args)] = None
            elif kind == "relation":
                for r in {*self._subs(subject), *self._supers(subject)}:
                    delete[Lit(r, args, False)] = None
            elif kind == "value" and atom.positive:
                add[Lit(atom.predicate, args)] = None
                for other in self.values[subject] - {atom.predicate}:
                    delete[Lit(other, args, False)] = None
                if subject in self.has:
                    add[Lit(f"has_{subject}", args)] = None
            elif kind == "has" and not atom.positive:
                for other in (atom.predicate, *sorted(self.values.get(subject, ()))):
                    delete[Lit(other, args, False)] = None
            elif kind == "empty" and atom.positive:
                subs = self._subs(subject)
                cls = self._class(d, args[0])
                single = cls != ROOT and self.onto.max_cardinality(cls, subject) == 1
                items = {
                    lit.args[1]
                    for lit in pre
                    if lit.positive and lit.pred in subs and lit.args[0] == args[0]
                }
                for sub in subs:
                    for r in (sub, *self._supers(sub)):
                        if single and items:  # it holds one thing at most: the one named
                            for item in items:
                                delete[Lit(r, (args[0], item), False)] = None
                        else:
                            forall[ForallDelete(sub, r, args[0], 1)] = None
            elif kind in ("value", "has", "opaque"):
                (add if atom.positive else delete)[Lit(atom.predicate, args, atom.positive)] = None
            # type atoms are static and negated empties are implied: no effect
        return ActionSchema(
            name=name,
            agent=d.agent.name,
            skill=d.desc.name,
            family=d.desc.family,
            duration=d.desc.duration,
            params=tuple(params),
            bound=dict(d.bound),
            pre=tuple(pre),
            empty_pre=tuple(empty_pre),
            add=tuple(add),
            delete=tuple(delete),
            forall_delete=tuple(forall),
            runtime_only=tuple(d.runtime_only),
        )


def _action_names(drafts: Sequence[_Draft]) -> list[str]:
    taken: set[str] = set()
    out = []
    for d in drafts:
        base = re.sub(r"[^A-Za-z0-9_]", "_", f"{d.desc.name}__{d.agent.name}")
        base = base if base[:1].isalpha() else f"a_{base}"
        name, n = base, 1
        while name.lower() in taken:
            n += 1
            name = f"{base}_{n}"
        taken.add(name.lower())
        out.append(name)
    return out


def build_task(
    agents: Sequence[AgentInfo],
    view: WorldView,
    goal: Goal,
    *,
    registry: ConditionRegistry | None = None,
    name: str = "skimesh",
) -> PlanningTask:
    """The planning task for ``goal`` with the skills of the available ``agents`` over the
    world model in ``view`` (see the module doc). DomainError if no skill is usable."""
    drafts: list[_Draft] = []
    skipped: list[str] = []
    for agent in agents:
        if not agent.available:
            continue
        for desc in agent.skills:
            draft = _draft(agent, desc, view, registry)
            if isinstance(draft, str):
                skipped.append(f"{desc.name} on {agent.name}: {draft}")
            else:
                drafts.append(draft)
    if not drafts:
        why = "; ".join(skipped) if skipped else "no available agent offers a skill"
        raise DomainError(f"no skill can be planned with: {why}")
    builder = _Builder(view, drafts, [literal_atom(lit) for lit in goal.literals])
    builder.predicates()
    hardware = {h for d in drafts for h in (*d.bound.values(), *d.agent.hardware)}
    builder.types(goal.elements() | hardware)
    init = builder.init()
    actions = {n: builder.action(d, n) for d, n in zip(drafts, _action_names(drafts), strict=True)}
    goal_lits = tuple(Lit(a.predicate, a.args, a.positive) for a in builder.goal_atoms)
    return PlanningTask(
        name=name,
        types=dict(builder.tree),
        objects=builder.objects,
        predicates=builder.names.predicates,
        init=frozenset(init),
        goal=goal_lits,
        actions=actions,
        skipped=tuple(skipped),
    )
