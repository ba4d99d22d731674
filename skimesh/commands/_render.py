"""Text rendering of world-model content for the terminal (trees, element lines, values);
elements are named by :func:`wm_store.display_name`."""

from __future__ import annotations

import re
from collections.abc import Iterable

from wm_store import display_name
from wm_store.protocol import (
    Color,
    Element,
    Frame,
    Orientation,
    Pose,
    Position,
    SizeCuboid,
    SizeCylinder,
    SizeSphere,
    Value,
)
from wm_store.scene import SceneState, id_sort_key

__all__ = ["element_line", "format_value", "plain_help", "render_tree"]

_ROLE = re.compile(r":(?:func|class|mod|meth|data|attr):`~?([^`]+)`")


def plain_help(doc: str | None) -> str | None:
    """A docstring as a command's help text: reST roles and double backquotes become the plain
    `name` a terminal shows (``wm_store.display_name`` -> `wm_store.display_name`)."""
    if doc is None:
        return None
    return _ROLE.sub(r"`\1`", doc).replace("``", "`")


def format_value(value: Value) -> str:
    """A short human form of a property value."""
    match value:
        case Position(x=x, y=y, z=z):
            return f"({x:.3f}, {y:.3f}, {z:.3f})"
        case Orientation(x=x, y=y, z=z, w=w):
            return f"quat({x:.3f}, {y:.3f}, {z:.3f}, {w:.3f})"
        case Pose(position=p, frame=frame):
            where = f" in {frame}" if frame else ""
            return f"({p.x:.3f}, {p.y:.3f}, {p.z:.3f}){where}"
        case Frame():
            return "frame(4x4)"
        case SizeCuboid(x=x, y=y, z=z):
            return f"{x:g}x{y:g}x{z:g} m"
        case SizeCylinder(radius=r, height=h):
            return f"cyl r={r:g} h={h:g} m"
        case SizeSphere(radius=r):
            return f"sphere r={r:g} m"
        case Color(r=r, g=g, b=b, a=a):
            return f"rgba({r:g}, {g:g}, {b:g}, {a:g})"
        case float():
            return f"{value:g}"
        case list():
            return "[" + ", ".join(format_value(v) for v in value) + "]"
        case str() if len(value) > 40:
            return repr(value[:37] + "...")
        case str():
            return repr(value)
    return str(value)


_SHOWN = ("pose", "position", "size", "available", "doorOpen", "heating", "mass")


def element_line(element: Element, shown: Iterable[str] = _SHOWN) -> str:
    """``Pulley-4 (Gear-1) [Gear]  pose=...``: the element's name (:func:`wm_store.display_name`),
    its class and the ``shown`` properties it has."""
    props = " ".join(
        f"{k}={format_value(element.properties[k])}" for k in shown if k in element.properties
    )
    return f"{display_name(element)} [{element.type}]" + (f"  {props}" if props else "")


def render_tree(state: SceneState, roots: Iterable[str] | None = None) -> str:
    """The spatial tree (``contain``, ``hasA``, ...) as indented text, one element a line.

    Without ``roots``, every element with no spatial parent is a root.
    """
    if roots is None:
        roots = sorted((i for i in state.elements if state.parent(i) is None), key=id_sort_key)
    lines: list[str] = []

    def walk(element_id: str, prefix: str) -> None:
        children = state.spatial_children(element_id)
        for i, rel in enumerate(children):
            branch, indent = ("└── ", "    ") if i == len(children) - 1 else ("├── ", "│   ")
            child = state.elements[rel.object]
            lines.append(f"{prefix}{branch}{rel.predicate} → {element_line(child)}")
            walk(rel.object, prefix + indent)

    for root in roots:
        lines.append(element_line(state.elements[root]))
        walk(root, "")
    return "\n".join(lines)
