"""Faces whose names load on first use (PEP 562), so that a command that names no client starts
without the ontology (rdflib), the store or the reasoners."""

from __future__ import annotations

import importlib
import sys
from collections.abc import Callable, Mapping
from typing import Any

__all__ = ["lazy_getattr"]


def lazy_getattr(face: str, where: Mapping[str, str]) -> Callable[[str], Any]:
    """The module ``__getattr__`` of the face ``face``: a name of ``where`` (name -> its module,
    relative to the face) is imported on first use and kept in the face's namespace."""

    def load(name: str) -> Any:
        if name not in where:
            raise AttributeError(f"module {face!r} has no attribute {name!r}")
        value = getattr(importlib.import_module(where[name], face), name)
        setattr(sys.modules[face], name, value)
        return value

    return load
