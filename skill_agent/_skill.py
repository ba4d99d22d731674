"""The skill implementation contract: :class:`Skill` and what it receives, :class:`SkillContext`.

A skill is a *description* (a :class:`~skill_agent.protocol.SkillDescription`: parameters and
conditions, what the planner sees) plus an *implementation*: a subclass of :class:`Skill` with
four async methods. The agent runtime calls them in this order for each run::

    specify parameters -> pre_sense -> pre-conditions -> execute -> post_sense
        -> post-conditions -> commit effects (one world-model transaction)

Lifecycle methods (in the spirit of py_trees' ``setup / initialise / update / terminate``):

``pre_sense(ctx)``
    Called once before the pre-conditions are checked. Refresh what the conditions read (e.g.
    locate the object and write its pose to the world model). Skipped, and recorded as
    "trusted the world model", when every element named in :attr:`Skill.senses` was updated
    less than ``description.sensing_max_age`` seconds ago.
``execute(ctx)``
    The work. May take long; must ``await`` regularly (every await is a point where a stop
    request lands as cancellation, and :meth:`SkillContext.checkpoint` is where a pause holds;
    a motion under way on a pausable device is held by the device itself).
    Raise :class:`~skill_agent.SkillFailure` to fail with a message. Report progress
    with :meth:`SkillContext.progress`. Hold-conditions are watched meanwhile; if one turns
    false the run is cancelled.
``post_sense(ctx)``
    Called after ``execute``: observe the outcome (e.g. verify the part is in the box). Same
    skipping rule as ``pre_sense``.
``on_preempt(ctx)``
    Called (shielded from cancellation, with a time limit) after the run was stopped, timed
    out or violated a hold-condition: bring the hardware to a safe state. Must be idempotent.

No method may block the event loop: long computations go through ``anyio.to_thread``; device
drivers offer async calls.
"""

from __future__ import annotations

import logging
from collections.abc import Mapping, Sequence
from typing import TYPE_CHECKING, ClassVar, Protocol, TypeVar, runtime_checkable

from skill_agent.protocol._skills import SkillDescription
from wm_store.protocol import Element, Op, Query, Relation, Value

if TYPE_CHECKING:
    from wm_store.ontology import Ontology

__all__ = ["Skill", "SkillContext", "WorldView"]

T = TypeVar("T")


@runtime_checkable
class WorldView(Protocol):
    """Read access to the world model, as conditions and inference need it.

    :class:`wm_store.WmClient` is one (its local replica); the task layer's symbolic simulation
    provides another over a private copy of the scene.
    """

    @property
    def ontology(self) -> Ontology: ...

    def get_element(self, element_id: str) -> Element: ...

    def find_element(self, element_id: str) -> Element | None: ...

    def resolve_element(self, query: Query | None = None, *, type: str = "") -> list[Element]: ...

    def query_relation(
        self, subject: str = "", predicate: str = "", obj: str = ""
    ) -> list[Relation]: ...


class SkillContext(Protocol):
    """What a running skill gets from the agent. One context per run."""

    run_id: str
    agent: str
    description: SkillDescription
    params: Mapping[str, Value]
    """Every parameter, specified: element parameters hold element ids."""
    simulated: bool
    """True in simulated-outcome mode: there is no hardware; ``device()`` raises."""
    log: logging.Logger

    @property
    def wm(self) -> object:
        """The agent's :class:`wm_store.WmClient`, as this run's view: reads go to the agent's
        replica, and every transaction committed through it (``transact``,
        ``update_element``, ``add_element``, ``set_relation``, ``observe``, ...) is recorded
        in the agent's event log with the run and its step. Typed ``object`` here to keep
        this module free of the client; skills import ``WmClient`` and ``cast``."""
        ...

    def element(self, param: str) -> Element:
        """The current world-model element bound to an element parameter."""
        ...

    def device(self, param: str, kind: type[T]) -> T:
        """The driver of the device bound to hardware parameter ``param``, checked to be a
        ``kind`` (e.g. ``ctx.device("gripper", Gripper)``)."""
        ...

    async def progress(self, message: str, *, fraction: float = -1.0, step: str = "") -> None:
        """Publish a progress event for this run."""
        ...

    async def checkpoint(self) -> None:
        """Wait here while the run is paused; a quick no-op otherwise. Await it before each
        motion: the devices of a paused run hold their motions, and a skill that checks here
        starts no new one."""
        ...

    async def transact(self, ops: Sequence[Op]) -> int:
        """Commit ``ops`` in one world-model transaction (recorded in the event log, like
        every write through :attr:`wm`); returns its revision."""
        ...


class Skill:
    """Base class of skill implementations. Subclasses set :attr:`description` and override
    :meth:`execute` (and, where they sense or move hardware, the other three)."""

    description: ClassVar[SkillDescription]
    senses: ClassVar[Sequence[str]] = ()
    """Element parameters whose world-model data ``pre_sense`` / ``post_sense`` refresh."""
    success_probability: ClassVar[float] = 1.0
    """Default probability of success in simulated-outcome mode (config may override)."""
    ontology: ClassVar[Sequence[str]] = ()
    """Turtle files with the ontology terms this skill needs (e.g. a data property its
    post-condition sets), relative to the file that defines the class. The agent teaches them
    to the world model before it checks its skills: every process of the mesh has them."""

    async def pre_sense(self, ctx: SkillContext) -> None:
        """Refresh what the pre-conditions read. Default: nothing to sense."""

    async def execute(self, ctx: SkillContext) -> None:
        """Do the work. Default: nothing (a purely symbolic skill)."""

    async def post_sense(self, ctx: SkillContext) -> None:
        """Observe the outcome before the post-conditions are checked. Default: nothing."""

    async def on_preempt(self, ctx: SkillContext) -> None:
        """Bring the hardware to a safe state after a stop. Default: nothing to do."""
