"""Property values in words, short, the same wherever people read them: what
:class:`~wm_store.ChangeWords` shows of a value that changed and what ``skimesh wm tree`` / ``ls``
show of an element (``(1.078, -1.250, 0.720)`` for a pose, millimetre precision;
``0.24x0.3x0.07 m`` for a size)."""

from __future__ import annotations

import math
from collections.abc import Callable

from wm_store.protocol import (
    Color,
    Frame,
    Orientation,
    Pose,
    Position,
    SizeCuboid,
    SizeCylinder,
    SizeSphere,
    Value,
)

__all__ = ["value_text"]

_LONG = 48
"""A text longer than this is cut (with an ellipsis)."""
_FLAT = 1e-9
"""An orientation whose x and y are under this is a yaw."""
_LIST_ITEMS = 4
"""A list with more items than this is counted, not shown."""


def _xyz(x: float, y: float, z: float) -> str:
    return f"({x:.3f}, {y:.3f}, {z:.3f})"


def _number(value: float) -> str:
    return f"{round(value, 3):g}"


def _in(frame: str, name_of: Callable[[str], str]) -> str:
    return f" in {name_of(frame)}" if frame else ""


def value_text(value: Value, name_of: Callable[[str], str] = str) -> str:
    """``value`` as a person reads it: positions (and the position of a pose or a frame) to
    the millimetre, an orientation as a yaw in degrees where
    it is one, numbers to three decimals, a frame named by ``name_of``, long texts cut,
    long lists counted; ``unset`` for None."""
    match value:
        case None:
            return "unset"
        case bool():
            return "true" if value else "false"
        case int():
            return str(value)
        case float():
            return _number(value)
        case str():
            text = value if len(value) <= _LONG else value[: _LONG - 1] + "…"
            return f'"{text}"'
        case Pose(position=p, orientation=o, frame=frame):
            turned = "" if o == Orientation(frame=o.frame) else f" {value_text(o)}"
            return _xyz(p.x, p.y, p.z) + turned + _in(frame or p.frame, name_of)
        case Position(x=x, y=y, z=z, frame=frame):
            return _xyz(x, y, z) + _in(frame, name_of)
        case Orientation(x=x, y=y, z=z, w=w):
            if abs(x) < _FLAT and abs(y) < _FLAT:  # a turn about the vertical
                return f"yaw {math.degrees(2 * math.atan2(z, w)):.1f}°"
            return f"q({x:.3f}, {y:.3f}, {z:.3f}, {w:.3f})"
        case Frame(matrix=m, frame=frame):
            at = _xyz(m[3], m[7], m[11]) if len(m) == 16 else f"{len(m)} numbers"
            return at + _in(frame, name_of)
        case SizeCuboid(x=x, y=y, z=z):
            return f"{_number(x)}x{_number(y)}x{_number(z)} m"
        case SizeCylinder(radius=r, height=h):
            return f"cyl r={_number(r)} h={_number(h)} m"
        case SizeSphere(radius=r):
            return f"sphere r={_number(r)} m"
        case Color(r=r, g=g, b=b, a=a):
            return f"rgba({r:.2f}, {g:.2f}, {b:.2f}, {a:.2f})"
        case list():
            if len(value) > _LIST_ITEMS:
                return f"[{len(value)} items]"
            return "[" + ", ".join(value_text(v, name_of) for v in value) + "]"
