"""What is wrong inside a typed value (:func:`typed_problem`): part of the check
:meth:`Ontology.check_value` runs on every write, so it imports no RDF library."""

from __future__ import annotations

import math

from wm_store.ontology._terms import kind_of
from wm_store.protocol import (
    Color,
    Frame,
    Orientation,
    Pose,
    Position,
    SizeCuboid,
    SizeCylinder,
    SizeSphere,
    TypedValue,
)

__all__ = ["typed_problem"]


def _is(obj: object, cls: type) -> bool:
    """isinstance, for fields whose declared type a caller may not have respected."""
    return isinstance(obj, cls)


def _bad_numbers(nums: tuple[object, ...], low: float | None, high: float | None) -> bool:
    return not all(
        isinstance(n, int | float)
        and not isinstance(n, bool)
        and math.isfinite(n)
        and (low is None or n >= low)
        and (high is None or n <= high)
        for n in nums
    )


def typed_problem(value: TypedValue) -> str | None:
    """What is wrong inside a typed value (non-finite numbers, negative sizes, colour channels
    outside [0, 1], a Frame without 16 numbers, a frame that is not a string), or None."""
    frames: tuple[object, ...] = ()
    match value:
        case Position(x, y, z, frame):
            bad, frames = _bad_numbers((x, y, z), None, None), (frame,)
        case Orientation(x, y, z, w, frame):
            bad, frames = _bad_numbers((x, y, z, w), None, None), (frame,)
        case Pose(position, orientation, frame):
            if not (_is(position, Position) and _is(orientation, Orientation)):
                return "a Pose holds a Position and an Orientation"
            inner = typed_problem(position) or typed_problem(orientation)
            if inner:
                return inner
            bad, frames = False, (frame,)
        case Frame(matrix, frame):
            if len(matrix) != 16:
                return f"a Frame needs 16 numbers (row-major 4x4), got {len(matrix)}"
            bad, frames = _bad_numbers(tuple(matrix), None, None), (frame,)
        case SizeCuboid(x, y, z):
            bad = _bad_numbers((x, y, z), 0.0, None)
        case SizeCylinder(radius, height):
            bad = _bad_numbers((radius, height), 0.0, None)
        case SizeSphere(radius):
            bad = _bad_numbers((radius,), 0.0, None)
        case Color(r, g, b, a):
            bad = _bad_numbers((r, g, b, a), 0.0, 1.0)
            if bad:
                return f"colour channels must be numbers in [0, 1]: {value!r}"
    if bad:
        low = " >= 0" if kind_of(value) in ("SizeCuboid", "SizeCylinder", "SizeSphere") else ""
        return f"{type(value).__name__} needs finite numbers{low}: {value!r}"
    if not all(isinstance(f, str) for f in frames):
        return f"the frame of {value!r} must be an element id (a string)"
    return None
