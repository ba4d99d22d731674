"""Simulated-outcome mode (FRIEND II): run skills with no hardware, outcomes drawn at random.

In this mode a run checks its pre-conditions against the world model as usual, but calls none
of ``pre_sense`` / ``execute`` / ``post_sense``: it waits ``duration * time_scale`` seconds
(default 0, stop and pause still apply), then draws success with the skill's probability. On
success the post-conditions' effects are committed to the world model; on failure the run ends
with reason ``execution`` and nothing is written. This tests task structures (sequences,
fallbacks, replanning) quickly and reproducibly.

The probability of a skill is looked up, first match wins: ``probabilities[name]``,
``probabilities[skill_type]``, the implementation's own ``Skill.success_probability`` when its
class sets one, then ``default``. Each instance owns its random generator (``seed`` makes the
sequence of draws reproducible); there is no global RNG.
"""

from __future__ import annotations

import random
from collections.abc import Mapping

import anyio

from skill_agent._errors import SkillLoadError
from skill_agent._skill import Skill
from skill_agent.protocol._skills import SkillDescription

__all__ = ["SimulatedOutcomes", "skill_probability"]


def skill_probability(skill: type[Skill]) -> float | None:
    """The ``success_probability`` a skill class (or a base below :class:`Skill`) sets, if
    any."""
    for cls in skill.__mro__:
        if cls is Skill:
            return None
        if "success_probability" in vars(cls):
            return float(vars(cls)["success_probability"])
    return None


class SimulatedOutcomes:
    """Per-skill success probabilities and the generator that draws outcomes."""

    def __init__(
        self,
        probabilities: Mapping[str, float] | None = None,
        default: float = 1.0,
        seed: int | None = None,
        *,
        time_scale: float = 0.0,
    ) -> None:
        self.probabilities = dict(probabilities or {})
        self.default = default
        self.seed = seed
        self.time_scale = time_scale
        for name, p in [*self.probabilities.items(), ("<default>", default)]:
            if not 0.0 <= p <= 1.0:
                raise SkillLoadError(f"success probability of {name} must be in [0, 1], not {p}")
        if time_scale < 0:
            raise SkillLoadError(f"time_scale must be >= 0, not {time_scale}")
        self._rng = random.Random(seed)

    def probability(
        self, name: str, *, family: str = "", implementation: type[Skill] | None = None
    ) -> float:
        """The probability of success of skill ``name`` (see the module docstring)."""
        if name in self.probabilities:
            return self.probabilities[name]
        if family and family in self.probabilities:
            return self.probabilities[family]
        own = None if implementation is None else skill_probability(implementation)
        return self.default if own is None else own

    async def play(self, description: SkillDescription, implementation: type[Skill]) -> str | None:
        """One simulated execution: wait ``duration * time_scale`` seconds (a cancellation
        point), then draw; returns None on success, else the failure message."""
        if self.time_scale and description.duration:
            await anyio.sleep(description.duration * self.time_scale)
        name, family = description.name, description.family
        if self.draw(name, family=family, implementation=implementation):
            return None
        p = self.probability(name, family=family, implementation=implementation)
        return f"simulated failure (p(success) = {p:g})"

    def draw(
        self, name: str, *, family: str = "", implementation: type[Skill] | None = None
    ) -> bool:
        """Draw one outcome: ``True`` with the skill's probability. Never blocks."""
        p = self.probability(name, family=family, implementation=implementation)
        return self._rng.random() < p
