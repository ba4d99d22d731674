"""The verifier: :func:`check` and :func:`verify` walk a task file's blocks in document order
and simulate its steps symbolically (the checks and the rules are in
:mod:`task_agent.verification`)."""

from __future__ import annotations

from collections import defaultdict
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Literal

import msgspec

from skill_agent import SkillError, WorldView
from skill_agent.conditions import effects
from skill_agent.protocol import SkillDescription
from wm_store import WmError
from wm_store.protocol import Op, Value
from wm_store.scene import SceneState, apply_transaction, id_sort_key

from ..discovery import AgentInfo
from ..protocol import Call, Parallel, TaskFile, VerifyProblem
from ..taskfile import ROOT_PATH, BlockSite, CallSite, assign_ids, blocks, walk, where
from ._attempt import Attempt, Earlier, Kind
from ._call import CallChecker, broken
from ._resources import (
    Sharing,
    call_locks,
    resource_problems,
    sharing,
    spot_problems,
    spots_of,
)
from ._scene import SceneView, changes, clashes, scene_copy

__all__ = ["Report", "StepPrediction", "check", "verify"]

Level = Literal["error", "warning", "note"]
_RANK = {k: i for i, k in enumerate(("structure", "unknown", "dataflow", "type", "resource"))}


class StepPrediction(msgspec.Struct, frozen=True, kw_only=True):
    """How one call is predicted to run: its agent, every parameter (inferred ones included,
    with the reasons), the effects it commits and the devices it locks."""

    path: str
    agent: str
    skill: str
    params: dict[str, Value]
    inferred: dict[str, str] = {}
    effects: list[Op] = []
    locks: list[str] = []


@dataclass
class Report:
    """What :func:`check` found; ``ok`` when there is no problem (warnings and notes do not
    fail a task)."""

    problems: list[VerifyProblem]
    warnings: list[VerifyProblem]
    notes: list[VerifyProblem]
    steps: list[StepPrediction]
    """The calls that could be specified, in document order."""
    final: SceneView
    """The predicted world model after the last step (a private copy)."""

    @property
    def ok(self) -> bool:
        return not self.problems


Branch = tuple[BlockSite, SceneState, list[list[Op]]]


class _Verifier:
    def __init__(self, task: TaskFile, view: WorldView, agents: Sequence[AgentInfo]) -> None:
        self.task = assign_ids(task)
        self.ontology = view.ontology
        self.state = scene_copy(view)
        self.sites = {s.path: s for s in blocks(self.task)}
        self.calls = {s.path: s for s in walk(self.task)}
        ids: dict[str, list[BlockSite]] = defaultdict(list)
        for site in self.sites.values():
            ids[site.block.id].append(site)
        self.ids = dict(ids)
        self.descs: dict[str, SkillDescription] = {}
        self.steps: dict[str, StepPrediction] = {}
        self.params: dict[str, dict[str, Value]] = {}
        self.locks: dict[str, set[str]] = {}
        self.sharing: dict[str, Sharing] = {}
        self.spots: dict[str, set[tuple[str, str]]] = {}
        """Each call's places for one robot it sends a robot to (place, robot)."""
        self.starts: dict[str, tuple[SceneState, Attempt]] = {}
        """The state each call in a parallel block starts in, with its attempt."""
        earlier = Earlier(self.ids, self.calls, self.descs, self.params)
        self.checker = CallChecker(agents, earlier)
        self.found: list[tuple[int, int, int, Level, VerifyProblem]] = []
        self.last_error = ""
        """Why the last :meth:`commit` failed."""

    def report(self, path: str, kind: Kind, message: str, level: Level = "error") -> None:
        site = self.sites[path]
        problem = VerifyProblem(path=where(path, site.block), kind=kind, message=message)
        self.found.append(
            (site.order, _RANK.get(kind, len(_RANK)), len(self.found), level, problem)
        )

    def result(self) -> Report:
        by_level: dict[str, list[VerifyProblem]] = defaultdict(list)
        for *_, level, problem in sorted(self.found, key=lambda f: f[:3]):
            by_level[level].append(problem)
        steps = [self.steps[p] for p in self.calls if p in self.steps]
        final = SceneView(self.state, self.ontology)
        return Report(by_level["error"], by_level["warning"], by_level["note"], steps, final)

    # ------------------------------------------------------------------ structure

    def structure(self) -> None:
        for site in self.sites.values():
            block = site.block
            if isinstance(block, Call):
                if not block.skill:
                    self.report(site.path, "structure", "a call needs a 'skill'")
                continue
            kind = "parallel" if isinstance(block, Parallel) else "sequence"
            if not block.children:
                self.report(site.path, "structure", f"an empty {kind} block: add calls or drop it")
            elif kind == "parallel" and len(block.children) == 1:
                message = (
                    "a parallel block with one child runs like a sequence; drop the block or "
                    "add the calls meant to run at the same time"
                )
                self.report(site.path, "structure", message, "warning")
        for bid, sites in self.ids.items():
            first = where(sites[0].path, sites[0].block)
            for site in sites[1:]:
                message = (
                    f"id '{bid}' is also used by {first}; ids must be unique "
                    "('@<step id>.<param>' names a step by its id)"
                )
                self.report(site.path, "structure", message)

    # ------------------------------------------------------------------ simulation

    def run(self, site: BlockSite, state: SceneState, journal: list[list[Op]]) -> None:
        """Simulate ``site`` on ``state``; append each committed batch of ops to ``journal``."""
        block = site.block
        if isinstance(block, Call):
            self.step(self.calls[site.path], state, journal)
            return
        children = [self.sites[f"{site.path}.{i}"] for i in range(len(block.children))]
        if not isinstance(block, Parallel):
            for child in children:
                self.run(child, state, journal)
            return
        branches: list[Branch] = []
        for child in children:
            branch, branch_journal = state.copy(), list[list[Op]]()
            branch.revision = state.revision
            self.run(child, branch, branch_journal)
            branches.append((child, branch, branch_journal))
        clashing = self.conflicts(site, state, branches)
        self.interference(branches, clashing)
        for i, (child, _, batches) in enumerate(branches):
            for ops in batches:
                if not self.commit(state, ops) and not any(i in pair for pair in clashing):
                    message = (
                        f"the effects of branch {where(child.path, child.block)} cannot be "
                        f"combined with the other branches': {self.last_error}"
                    )
                    self.report(site.path, "precondition", message)
                journal.append(ops)

    def commit(self, state: SceneState, ops: list[Op]) -> bool:
        try:
            apply_transaction(state, self.ontology, ops, revision=state.revision + 1, now=0.0)
        except WmError as exc:
            self.last_error = str(exc)
            return False
        state.revision += 1
        return True

    def conflicts(
        self, site: BlockSite, before: SceneState, branches: list[Branch]
    ) -> set[frozenset[int]]:
        """Report facts two branches change differently; the pairs of such branches."""
        changed = [changes(before, state) for _, state, _ in branches]
        clashing: set[frozenset[int]] = set()
        for i in range(len(branches)):
            for j in range(i + 1, len(branches)):
                names = tuple(where(b[0].path, b[0].block) for b in (branches[i], branches[j]))
                for text in clashes(changed[i], changed[j], (names[0], names[1])):
                    clashing.add(frozenset((i, j)))
                    message = (
                        f"branches {names[0]} and {names[1]} may run at the same time and both "
                        f"change {text}; the outcome depends on timing: order them in a sequence"
                    )
                    self.report(site.path, "precondition", message)
        return clashing

    def interference(self, branches: list[Branch], clashing: set[frozenset[int]]) -> None:
        """Report conditions of a branch's calls that a sibling branch's effects, at any point,
        make false: the sibling may run first or meanwhile (pre-conditions) or while the call
        runs (hold-conditions)."""
        for i, (mine, _, _) in enumerate(branches):
            inside = [p for p in self.starts if p == mine.path or p.startswith(f"{mine.path}.")]
            for j, (other, _, batches) in enumerate(branches):
                if i == j or frozenset((i, j)) in clashing:
                    continue
                for path in inside:
                    self.interfered(path, other, batches)

    def interfered(self, path: str, other: BlockSite, batches: list[list[Op]]) -> None:
        start, att = self.starts[path]
        already = {id(c) for _, c, _ in broken(att, SceneView(start, self.ontology))}
        probe = start.copy()
        for ops in batches:
            if not self.commit(probe, ops):
                continue
            for text, cond, reason in broken(att, SceneView(probe, self.ontology)):
                if id(cond) not in already:
                    already.add(id(cond))
                    message = (
                        f"{att.desc.name} on {att.agent.name}: {text} may be made false by "
                        f"branch {where(other.path, other.block)}, which may run at the same "
                        f"time: {reason}; order them in a sequence"
                    )
                    self.report(path, "precondition", message)

    def choices(self, site: CallSite, offering: list[AgentInfo]) -> list[AgentInfo]:
        """The agents an agent-less call may run on: the task agent takes the first idle agent
        offering the skill (by name), so every one up to the first that no concurrent call
        can occupy."""
        if len(offering) == 1:
            return offering
        busy: set[str] = set()
        for path in site.parallel:
            other = self.checker.candidates(self.calls[path].call)
            busy |= {a.name for a in other} if isinstance(other, list) else set()
        out = []
        for agent in offering:
            out.append(agent)
            if agent.name not in busy:
                break
        return out

    def step(self, site: CallSite, state: SceneState, journal: list[list[Op]]) -> None:
        found = self.checker.candidates(site.call)
        if isinstance(found, str):
            self.report(site.path, "unknown", found)
            return
        view = SceneView(state, self.ontology)
        found = self.choices(site, found)
        attempts = [self.checker.attempt(site, agent, view) for agent in found]
        failed = next((a for a in attempts if a.problems), None)
        att = next((a for a in attempts if not a.problems), attempts[0])
        self.descs[site.path] = att.desc
        head = f"{att.desc.name} on {att.agent.name}: "
        if failed is not None and len(found) > 1:
            names = ", ".join(a.name for a in found)
            head = (
                f"no agent named, so the task agent takes the first idle one offering "
                f"{att.desc.name} ({names}); on {failed.agent.name}: "
            )
        for kind, message in (failed or att).problems:
            self.report(site.path, kind, head + message)
        for kind, message in att.warnings:
            self.report(site.path, kind, head + message, "warning")
        self.locks[site.path] = call_locks(att, view, fixed=len(found) == 1)
        self.sharing[site.path] = sharing(att, fixed=len(found) == 1)
        self.spots[site.path] = spots_of(att, view)
        if att.values is None:
            return
        hardware = {p.name for p in att.desc.parameters if p.kind == "hardware"}
        for name, reason in att.inferred.items():
            if name not in hardware:
                self.report(
                    site.path, "dataflow", f"{head}'{name}' will be inferred: {reason}", "note"
                )
        start = state.copy() if site.parallel else state
        try:
            ops = effects(att.desc.post, view, att.values)
        except SkillError as exc:
            self.report(site.path, "precondition", f"{head}cannot predict its effects: {exc}")
            ops = []
        if not self.commit(state, ops):
            message = f"{head}its predicted effects cannot be committed: {self.last_error}"
            self.report(site.path, "precondition", message)
        journal.append(ops)
        self.params[site.path] = att.values
        if site.parallel:  # for the check against parallel branches (interference)
            self.starts[site.path] = (start, att)
        self.steps[site.path] = StepPrediction(
            path=site.path,
            agent=att.agent.name,
            skill=att.desc.name,
            params=att.values,
            inferred=att.inferred,
            effects=ops,
            locks=sorted(self.locks[site.path], key=id_sort_key),
        )

    def resources(self) -> None:
        for path, message in resource_problems(self.calls, self.locks, self.state, self.sharing):
            self.report(path, "resource", message)
        for path, message in spot_problems(self.calls, self.spots, self.state):
            self.report(path, "resource", message)


def check(task: TaskFile, view: WorldView, agents: Sequence[AgentInfo]) -> Report:
    """Verify ``task`` against the world model ``view`` (left unchanged: the simulation runs on
    a private copy) and the discovered ``agents`` (see the module doc)."""
    verifier = _Verifier(task, view, agents)
    verifier.structure()
    verifier.run(verifier.sites[ROOT_PATH], verifier.state, [])
    verifier.resources()
    return verifier.result()


def verify(task: TaskFile, view: WorldView, agents: Sequence[AgentInfo]) -> list[VerifyProblem]:
    """Every problem of ``task`` (empty: it verifies), in document order (see :func:`check`)."""
    return check(task, view, agents).problems
