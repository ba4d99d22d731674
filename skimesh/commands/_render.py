"""Text rendering of world-model content for the terminal (trees, element lines); elements are
named by :func:`wm_store.display_name`, values worded by :func:`wm_store.value_text`."""

from __future__ import annotations

import re
from collections.abc import Iterable

from wm_store import display_name, value_text
from wm_store.protocol import Element
from wm_store.scene import SceneState, id_sort_key

__all__ = ["element_line", "plain_help", "render_tree"]

_ROLE = re.compile(r":(?:func|class|mod|meth|data|attr):`~?([^`]+)`")


def plain_help(doc: str | None) -> str | None:
    """A docstring as a command's help text: reST roles and double backquotes become the plain
    `name` a terminal shows (``wm_store.display_name`` -> `wm_store.display_name`)."""
    if doc is None:
        return None
    return _ROLE.sub(r"`\1`", doc).replace("``", "`")


_SHOWN = ("pose", "position", "size", "available", "doorOpen", "heating", "mass")


def element_line(element: Element, shown: Iterable[str] = _SHOWN) -> str:
    """``Pulley-4 (Gear-1) [Gear]  pose=...``: the element's name (:func:`wm_store.display_name`),
    its class and the ``shown`` properties it has."""
    props = " ".join(
        f"{k}={value_text(element.properties[k])}" for k in shown if k in element.properties
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
