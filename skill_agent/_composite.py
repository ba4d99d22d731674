"""Composite skills: behaviour-tree nodes over sub-skills run by the same agent.

A :class:`CompositeSkill` is a skill whose ``execute`` walks a tree of nodes; every leaf
:class:`Step` is a *sub-run* started through the agent (``ctx.run_child``): it specifies its own
parameters, locks its own devices (borrowing the ones its ancestors hold), checks its own
conditions and emits its own progress and result (run id ``<parent>.<n>``). Stopping the parent
cancels the running children, whose ``on_preempt`` runs first.

Nodes (msgspec Structs, tag field ``node``, so task structures can travel on the wire):

- ``Step(skill, params)``: ``params`` maps each *child* parameter to a *parent* parameter name,
  or to ``"=<literal>"`` (JSON if it parses: ``"=0.5"``, ``"=true"``; else the text). Child
  parameters left out are specified by the child itself (defaults, inference, the agent's
  devices). Nothing is remapped silently: :func:`check_composite` (at load) refuses a mapping
  to an unknown parameter on either side, incompatible types (ontology ``is_a`` for element
  parameters) and an unmapped required value parameter that cannot be inferred.
- ``Sequence(children)``: all in order; the first failure fails the node.
- ``Selector(children)``: fallback; the first success wins; fails when all fail.
- ``Parallel(children, mode)``: at once; ``"all"``: all must succeed (one failure stops the
  others); ``"first"``: the first success wins and stops the others; fails when all fail.
- ``Retry(child, times)``: up to ``times`` attempts in total.

A failed node raises :class:`~skill_agent.SkillFailure` (the run ends ``execution``).
"""

from __future__ import annotations

import difflib
from collections.abc import Mapping
from typing import TYPE_CHECKING, Annotated, ClassVar, Literal, Protocol, TypeAlias

import anyio
import msgspec
from msgspec import Meta

from skill_agent._errors import SkillError, SkillFailure, SkillLoadError, leaves
from skill_agent._skill import Skill, SkillContext
from skill_agent.protocol._runs import RunResult
from skill_agent.protocol._skills import ParamSpec, SkillDescription
from wm_store.protocol import Value

if TYPE_CHECKING:
    from wm_store.ontology import Ontology

__all__ = [
    "ChildContext",
    "CompositeSkill",
    "Node",
    "Parallel",
    "Retry",
    "Selector",
    "Sequence",
    "Step",
    "check_composite",
    "literal",
    "run_node",
]


class Step(msgspec.Struct, tag=True, tag_field="node", frozen=True):
    skill: str
    params: dict[str, str] = {}


class Sequence(msgspec.Struct, tag=True, tag_field="node", frozen=True):
    children: list[Node]


class Selector(msgspec.Struct, tag=True, tag_field="node", frozen=True):
    children: list[Node]


class Parallel(msgspec.Struct, tag=True, tag_field="node", frozen=True):
    children: list[Node]
    mode: Literal["all", "first"] = "all"


class Retry(msgspec.Struct, tag=True, tag_field="node", frozen=True):
    child: Node
    times: Annotated[int, Meta(ge=1)] = 2


Node: TypeAlias = Step | Sequence | Selector | Parallel | Retry


class ChildContext(SkillContext, Protocol):
    """A skill context that can start sub-runs (``skill_agent.runtime.RunContext`` is one)."""

    async def run_child(self, skill: str, params: Mapping[str, Value]) -> RunResult: ...


class CompositeSkill(Skill):
    """Base class: set ``description`` and ``tree``. ``execute`` runs the tree; in
    simulated-outcome mode the children run simulated."""

    tree: ClassVar[Node]
    runs_children: ClassVar[bool] = True

    async def execute(self, ctx: SkillContext) -> None:
        if not hasattr(ctx, "run_child"):
            raise SkillFailure(f"{self.description.name}: this context cannot run sub-skills")
        await run_node(self.tree, ctx)  # type: ignore[arg-type]  # checked just above


def literal(text: str) -> Value:
    """The value of a ``"=<literal>"`` mapping (without the ``=``)."""
    try:
        value: Value = msgspec.json.decode(text, type=Value)
        return value
    except msgspec.DecodeError:
        return text


def _child_params(step: Step, parent: Mapping[str, Value]) -> dict[str, Value]:
    values: dict[str, Value] = {}
    for child, source in step.params.items():
        value = literal(source[1:]) if source.startswith("=") else parent.get(source)
        if value is not None:
            values[child] = value
    return values


async def run_node(node: Node, ctx: ChildContext) -> None:
    """Run ``node``; returns on success, raises SkillFailure on failure. Blocks until done."""
    match node:
        case Step(skill=skill):
            try:
                result = await ctx.run_child(skill, _child_params(node, ctx.params))
            except SkillFailure:
                raise
            except SkillError as exc:
                raise SkillFailure(f"{skill} refused: [{exc.code}] {exc}") from exc
            if not result.success:
                raise SkillFailure(f"{skill} ({result.run_id}) {result.reason}: {result.message}")
        case Sequence(children=children):
            for child in children:
                await run_node(child, ctx)
        case Selector(children=children):
            failures: list[str] = []
            for child in children:
                try:
                    await run_node(child, ctx)
                    return
                except SkillFailure as exc:
                    failures.append(str(exc))
                    await ctx.progress(f"alternative failed: {exc}")
            raise SkillFailure("every alternative failed: " + " | ".join(failures))
        case Parallel(children=children, mode="all"):
            try:
                async with anyio.create_task_group() as tg:
                    for child in children:
                        tg.start_soon(run_node, child, ctx)
            except BaseExceptionGroup as group:
                _, rest = group.split(SkillFailure)
                if rest is not None:
                    raise
                raise SkillFailure(" | ".join(str(e) for e in leaves(group))) from group
        case Parallel(children=children):
            await _first(children, ctx)
        case Retry(child=child, times=times):
            for attempt in range(1, times + 1):
                try:
                    await run_node(child, ctx)
                    return
                except SkillFailure as exc:
                    if attempt == times:
                        raise SkillFailure(f"failed {times} times; last: {exc}") from exc
                    await ctx.progress(f"attempt {attempt}/{times} failed: {exc}; retrying")


async def _first(children: list[Node], ctx: ChildContext) -> None:
    failures: list[str] = []
    won = False
    async with anyio.create_task_group() as tg:

        async def attempt(child: Node) -> None:
            nonlocal won
            try:
                await run_node(child, ctx)
            except SkillFailure as exc:
                failures.append(str(exc))
                return
            won = True
            tg.cancel_scope.cancel()

        for child in children:
            tg.start_soon(attempt, child)
    if not won:
        raise SkillFailure("no branch succeeded: " + " | ".join(failures))


# --------------------------------------------------------------------------- load-time checks


def _closest(name: str, names: list[str]) -> str:
    match = difflib.get_close_matches(name, names, n=1)
    return f"; did you mean {match[0]!r}?" if match else f" (known: {', '.join(sorted(names))})"


def _compatible(source: str, target: str, ontology: Ontology) -> bool:
    classes = ontology.classes
    if target in classes or source in classes:
        return source in classes and target in classes and ontology.is_a(source, target)
    return source == target or (source == "int" and target == "float")


def _check_literal(text: str, spec: ParamSpec, ontology: Ontology) -> str | None:
    value = literal(text)
    kinds: dict[str, tuple[type, ...]] = {"float": (int, float), "int": (int,), "bool": (bool,)}
    expected = (
        (str,) if spec.type in ontology.classes or spec.type == "str" else kinds.get(spec.type)
    )
    if expected is None or isinstance(value, expected):
        return None
    return f"literal {text!r} is not a {spec.type}"


def check_composite(
    tree: Node,
    description: SkillDescription,
    skills: Mapping[str, SkillDescription],
    ontology: Ontology,
    *,
    trees: Mapping[str, Node] | None = None,
) -> None:
    """Check a composite's mappings against the child descriptions (at load).

    ``skills``: the descriptions of the skills the tree may use; ``trees``: the trees of the
    composite ones among them (for cycle detection). Raises SkillLoadError saying what to fix.
    """
    parent = {p.name: p for p in description.parameters}
    name = description.name
    for step in _steps(tree, name):
        child = skills.get(step.skill)
        if child is None:
            raise SkillLoadError(
                f"{name}: no skill {step.skill!r}{_closest(step.skill, [*skills])}"
            )
        specs = {p.name: p for p in child.parameters}
        for target, source in step.params.items():
            spec = specs.get(target)
            if spec is None:
                raise SkillLoadError(
                    f"{name}: {step.skill} has no parameter {target!r}{_closest(target, [*specs])}"
                )
            if source.startswith("="):
                problem = _check_literal(source[1:], spec, ontology)
                if problem:
                    raise SkillLoadError(f"{name}: {step.skill}.{target}: {problem}")
                continue
            origin = parent.get(source)
            if origin is None:
                raise SkillLoadError(
                    f"{name}: {step.skill}.{target} maps to {source!r}, which is no parameter"
                    f" of {name}{_closest(source, [*parent])}"
                )
            if not _compatible(origin.type, spec.type, ontology):
                raise SkillLoadError(
                    f"{name}: {step.skill}.{target} is a {spec.type}; {name}.{source} is a"
                    f" {origin.type}, which is not one"
                )
        for spec in child.parameters:
            inferable = spec.type in ontology.classes or spec.kind == "hardware"
            if spec.name in step.params or spec.optional or spec.default is not None:
                continue
            if not inferable:
                raise SkillLoadError(
                    f"{name}: {step.skill}.{spec.name} ({spec.type}) is not mapped and cannot be"
                    f" inferred: map it in Step.params (to a parameter of {name} or '=<value>')"
                )
    _check_cycles(name, tree, trees or {})


def _steps(node: Node, owner: str) -> list[Step]:
    match node:
        case Step():
            return [node]
        case Retry(child=child):
            return _steps(child, owner)
        case (
            Sequence(children=children) | Selector(children=children) | Parallel(children=children)
        ):
            if not children:
                raise SkillLoadError(f"{owner}: a {type(node).__name__} node has no children")
            return [s for c in children for s in _steps(c, owner)]


def _check_cycles(
    name: str, tree: Node, trees: Mapping[str, Node], path: tuple[str, ...] = ()
) -> None:
    path = (*path, name)
    for step in _steps(tree, name):
        if step.skill in path:
            raise SkillLoadError(f"composite cycle: {' -> '.join((*path, step.skill))}")
        sub = trees.get(step.skill)
        if sub is not None:
            _check_cycles(step.skill, sub, trees, path)
