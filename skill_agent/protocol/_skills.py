"""Skill descriptions as planners see them: parameters and conditions (all msgspec Structs).

Conditions are a tagged union (tag field ``cond``); :mod:`skill_agent.conditions` evaluates them.
"""

from __future__ import annotations

from typing import Annotated, Literal, TypeAlias

from msgspec import Meta, Struct

from wm_store.protocol import Comparator, Query, Value

SCHEMA_VERSION = 1

# --------------------------------------------------------------------------- parameters

ParamKind = Literal["online", "offline", "hardware"]

ParamState = Literal["initialized", "specified"]
"""A parameter's state (SkiROS): ``initialized`` while it has no value (declared, not given,
no default, not yet inferred), ``specified`` once it has one (given and checked, a default,
inferred, or a device bound). A run starts only when every required parameter is
``specified``; an optional parameter may stay ``initialized`` (its value is None)."""


class ParamSpec(Struct, frozen=True, kw_only=True):
    """One parameter of a skill.

    ``type`` is either an ontology class (an *element parameter*: its value is an element id,
    and any element of that class or a subclass fits) or a value kind (``float``, ``int``,
    ``bool``, ``str``, ``Pose``, ``Position``, ``Orientation``, ``SizeCuboid``, ... , ``list``).
    Kinds: ``online`` = the objects acted on, ``offline`` = configuration with defaults,
    ``hardware`` = devices of the robot (element parameters whose devices the run locks).
    ``partial`` narrows an element parameter further (SkiROS "partial definition"): label,
    property filters, relations (``?`` = the candidate).
    """

    name: str
    type: str
    kind: ParamKind = "online"
    doc: str = ""
    default: Value = None
    optional: bool = False
    partial: Query | None = None


# --------------------------------------------------------------------------- conditions
# Conditions are data: each has a run-time face (evaluated against the world model by
# skill_agent.conditions) and a symbolic face (a predicate for the planner). Parameter
# references are parameter names; a post-condition is also the skill's predicted effect.


class RelationCond(Struct, tag=True, tag_field="cond", frozen=True, kw_only=True):
    """``predicate(subject, object)`` holds (or, with ``holds=False``, does not)."""

    subject: str
    predicate: str
    object: str
    holds: bool = True


class PropertyCond(Struct, tag=True, tag_field="cond", frozen=True, kw_only=True):
    """``param.property <op> value`` (``near`` uses ``tolerance``)."""

    param: str
    property: str
    op: Comparator = "eq"
    value: Value = None
    tolerance: float = 0.0


class HasPropertyCond(Struct, tag=True, tag_field="cond", frozen=True, kw_only=True):
    param: str
    property: str
    holds: bool = True


class IsTypeCond(Struct, tag=True, tag_field="cond", frozen=True, kw_only=True):
    """The element bound to ``param`` is a ``cls`` (or a subclass)."""

    param: str
    cls: str


class EmptyCond(Struct, tag=True, tag_field="cond", frozen=True, kw_only=True):
    """The location/container/gripper ``param`` contains nothing (``holds=False``: something).
    With ``full=True``: it holds as many things as its ``capacity`` property allows."""

    param: str
    predicate: str = "contain"
    holds: bool = True
    full: bool = False


class IsSpecifiedCond(Struct, tag=True, tag_field="cond", frozen=True, kw_only=True):
    param: str


class CustomCond(Struct, tag=True, tag_field="cond", frozen=True, kw_only=True):
    """A condition class registered by name in the agent (``skill_agent.conditions``)."""

    name: str
    params: list[str] = []
    args: dict[str, Value] = {}


class AndCond(Struct, tag=True, tag_field="cond", frozen=True, kw_only=True):
    items: list[Condition]


class OrCond(Struct, tag=True, tag_field="cond", frozen=True, kw_only=True):
    items: list[Condition]


class NotCond(Struct, tag=True, tag_field="cond", frozen=True, kw_only=True):
    item: Condition


Condition: TypeAlias = (
    RelationCond
    | PropertyCond
    | HasPropertyCond
    | IsTypeCond
    | EmptyCond
    | IsSpecifiedCond
    | CustomCond
    | AndCond
    | OrCond
    | NotCond
)


class SkillDescription(Struct, frozen=True, kw_only=True):
    """What a skill does, as planners and other hosts see it."""

    name: str
    skill_type: str = ""
    """The family several implementations share (e.g. ``pick``); defaults to ``name``."""
    version: str = "1.0"
    doc: str = ""
    parameters: list[ParamSpec] = []
    pre: list[Condition] = []
    hold: list[Condition] = []
    """Must stay true while the skill executes; a violation aborts the run."""
    post: list[Condition] = []
    """Checked after ``post_sense``; their effects are committed to the world model."""
    duration: Annotated[float, Meta(ge=0)] = 1.0
    """Estimated seconds, used by the planner to balance robots."""
    timeout: Annotated[float, Meta(gt=0)] | None = None
    sensing_max_age: Annotated[float, Meta(ge=0)] | None = None
    """Skip sensing when the data it refreshes is younger than this (seconds)."""

    @property
    def family(self) -> str:
        return self.skill_type or self.name
