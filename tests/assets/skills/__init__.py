"""Example skills for the skill-agent tests (``tests.assets.skills``).

Every skill takes an optional :class:`Probe` (``Skill(probe)``); without one it makes its own.
:func:`entries` builds an agent catalog sharing one probe.
"""

from __future__ import annotations

from collections.abc import Callable

from skill_agent import Skill
from skill_agent.runtime import SkillEntry

from .basic import Buggy, Fail, Noop, ProbedSkill, Slow, Wait
from .kitting import Carry, FailThenNoop, Pick, PickAndPlace, Place, TrustingPick, Weigh
from .probe import Call, Probe

__all__ = [
    "ALL",
    "Buggy",
    "Call",
    "Carry",
    "Fail",
    "FailThenNoop",
    "Noop",
    "Pick",
    "PickAndPlace",
    "Place",
    "Probe",
    "ProbedSkill",
    "Slow",
    "TrustingPick",
    "Wait",
    "Weigh",
    "entries",
]

ALL: tuple[type[Skill], ...] = (
    Noop,
    Wait,
    Slow,
    Fail,
    Buggy,
    Pick,
    TrustingPick,
    Place,
    Carry,
    Weigh,
    PickAndPlace,
    FailThenNoop,
)


def entries(probe: Probe, *skills: type[Skill]) -> dict[str, SkillEntry]:
    """A catalog of ``skills`` (default: all), probed ones sharing ``probe``."""
    catalog: dict[str, SkillEntry] = {}
    for cls in skills or ALL:
        factory: Callable[[], Skill] = _probed(cls, probe) if issubclass(cls, ProbedSkill) else cls
        catalog[cls.description.name] = SkillEntry(
            description=cls.description, factory=factory, source=f"{cls.__module__}:{cls.__name__}"
        )
    return catalog


def _probed(cls: type[ProbedSkill], probe: Probe) -> Callable[[], Skill]:
    def make() -> Skill:
        return cls(probe)

    return make
