"""Resolution of a property reported by several sources (FRIEND II: a smart platform's footprint
and a camera both give an object's position).

Each source's latest report is kept as an :class:`~wm_store.protocol.Observation`; the value
skills read (``Element.properties[name]``) is chosen by the property's policy, declared in the
ontology (``skm:resolution``):

``latest``
    the most recent observation wins.
``most_confident``
    the highest confidence wins; ties go to the most recent.
``fused``
    numbers and positions are averaged, weighted by confidence; a pose fuses its position and
    takes the orientation of the most confident source. Any other kind falls back to
    ``most_confident``.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Literal

from wm_store.protocol import Observation, Pose, Position, Value

__all__ = ["ResolutionPolicy", "merge_observation", "resolve_observations"]

ResolutionPolicy = Literal["latest", "most_confident", "fused"]


def merge_observation(
    observations: Sequence[Observation], new: Observation, *, keep: int = 16
) -> list[Observation]:
    """Replace ``new.source``'s earlier observation (one per source), newest last, at most
    ``keep`` sources (the oldest are dropped)."""
    merged = [o for o in observations if o.source != new.source]
    merged.append(new)
    merged.sort(key=lambda o: o.stamp)
    return merged[-keep:]


def resolve_observations(observations: Sequence[Observation], policy: ResolutionPolicy) -> Value:
    """The value a property takes given its observations and the policy."""
    if not observations:
        return None
    if policy == "latest":
        return max(observations, key=lambda o: o.stamp).value
    best = max(observations, key=lambda o: (o.confidence, o.stamp))
    if policy == "most_confident" or len(observations) == 1:
        return best.value
    return _fuse(observations, best)


def _fuse(observations: Sequence[Observation], best: Observation) -> Value:
    weights = [max(o.confidence, 1e-9) for o in observations]
    total = sum(weights)
    numbers = [_number_of(o.value) for o in observations]
    if all(n is not None for n in numbers):
        return sum(n * w for n, w in zip(numbers, weights, strict=True) if n is not None) / total
    positions = [_position_of(o.value) for o in observations]
    known = [p for p in positions if p is not None]
    if len(known) != len(positions):
        return best.value
    frame = known[0].frame
    if any(p.frame != frame for p in known):
        return best.value  # different frames: do not average apples and oranges
    fused = Position(
        sum(p.x * w for p, w in zip(known, weights, strict=True)) / total,
        sum(p.y * w for p, w in zip(known, weights, strict=True)) / total,
        sum(p.z * w for p, w in zip(known, weights, strict=True)) / total,
        frame,
    )
    if isinstance(best.value, Pose):
        return Pose(Position(fused.x, fused.y, fused.z), best.value.orientation, frame)
    return fused


def _number_of(value: Value) -> float | None:
    if isinstance(value, int | float) and not isinstance(value, bool):
        return float(value)
    return None


def _position_of(value: Value) -> Position | None:
    if isinstance(value, Position):
        return value
    if isinstance(value, Pose):
        return Position(
            value.position.x,
            value.position.y,
            value.position.z,
            value.frame or value.position.frame,
        )
    return None
