"""Data property values and templates (default individuals) of a loaded ontology.

:class:`OntologyValues` is the layer of :class:`wm_store.ontology.Ontology` that checks a
value against a data property: its kind (an int is accepted as a float, a bool is not an int),
its numeric range widened by the tolerance, the shape of typed values, list or scalar, and the
property's domain. Templates are checked the same way when the ontology is built, and a class
with one template (or a ``Default<Class>``) has it as its default.
"""

from __future__ import annotations

import math
from collections import defaultdict
from collections.abc import Mapping
from types import MappingProxyType

from wm_store._errors import (
    PropertyValueError,
    UnknownClassError,
    UnknownPropertyError,
    UnknownTemplateError,
    ValidationError,
)
from wm_store.ontology._cardinality import OntologyCardinality
from wm_store.ontology._terms import (
    SCALAR_KINDS,
    TYPED_KINDS,
    WHERE_TERMS,
    DataPropertyInfo,
    Declarations,
    did_you_mean,
    kind_of,
    one_of,
    with_article,
)
from wm_store.ontology._typed import typed_problem
from wm_store.protocol import TemplateDef, Value

__all__ = ["OntologyValues"]


class OntologyValues(OntologyCardinality):
    """The data properties and templates of an :class:`~wm_store.ontology.Ontology`."""

    __slots__ = ("_tpl_by_class", "_value_kinds")

    def __init__(self, decl: Declarations) -> None:
        super().__init__(decl)
        # (kinds of scalars or list items, whether a bare scalar is accepted): "list" with
        # other kinds means a list of those; "any" (every kind) accepts scalars and lists
        self._value_kinds = {
            n: (
                p.kinds - {"list"} or SCALAR_KINDS,
                "list" not in p.kinds or p.kinds >= SCALAR_KINDS,
            )
            for n, p in decl.data_properties.items()
        }
        by_type: dict[str, list[str]] = defaultdict(list)
        for t in decl.templates.values():
            try:
                self._check_template(t)
            except (ValidationError, UnknownClassError) as exc:
                raise type(exc)(f"template '{t.name}': {exc}") from None
            by_type[t.type].append(t.name)
        self._tpl_by_class = {
            cls: names[0] if len(names) == 1 else f"Default{cls}"
            for cls, names in by_type.items()
            if len(names) == 1 or f"Default{cls}" in names
        }

    # ----------------------------------------------------------------------- data properties

    @property
    def data_properties(self) -> Mapping[str, DataPropertyInfo]:
        return MappingProxyType(self._decl.data_properties)

    def data_property(self, name: str) -> DataPropertyInfo:
        try:
            return self._decl.data_properties[name]
        except KeyError:
            hint = did_you_mean(name, self._decl.data_properties)
            raise UnknownPropertyError(
                f"unknown data property {name!r}{hint} {WHERE_TERMS}"
            ) from None

    def check_value(self, name: str, value: Value) -> None:
        """Raise PropertyValueError unless ``value`` fits property ``name``: its kind (an int is
        accepted as a float, a bool is not an int), its range widened by the tolerance, and
        the shape of typed values. ``None`` is always accepted; lists are checked item by item."""
        info = self._decl.data_properties.get(name) or self.data_property(name)
        kinds, scalar_ok = self._value_kinds[name]
        if value is None:
            return
        if isinstance(value, list):
            if "list" not in info.kinds:
                raise PropertyValueError(f"property '{name}' takes {one_of(kinds)}, not a list")
            for i, item in enumerate(value):
                self._check_scalar(info, kinds, item, f"item {i} of ")
        elif not scalar_ok:
            raise PropertyValueError(
                f"property '{name}' takes a list of {one_of(kinds)}, not {value!r}; "
                f"wrap it: [{value!r}]"
            )
        else:
            self._check_scalar(info, kinds, value, "")

    def _check_scalar(
        self, info: DataPropertyInfo, kinds: frozenset[str], value: object, where: str
    ) -> None:
        kind = kind_of(value)
        if kind is None or (kind not in kinds and not (kind == "int" and "float" in kinds)):
            got = f"{kind} {value!r}" if kind else f"{value!r} ({type(value).__name__})"
            raise PropertyValueError(
                f"{where}property '{info.name}' takes {one_of(kinds)}, got {got}"
            )
        if isinstance(value, int | float) and not isinstance(value, bool):
            low, high, tol = info.minimum, info.maximum, info.tolerance
            if not math.isfinite(value):
                raise PropertyValueError(f"{where}property '{info.name}': {value} is not finite")
            if (low is not None and value < low - tol) or (high is not None and value > high + tol):
                bounds = f"[{'-inf' if low is None else low}, {'inf' if high is None else high}]"
                raise PropertyValueError(
                    f"{where}property '{info.name}' must be within {bounds} (tolerance {tol}); "
                    f"got {value!r}. Fix the value or its source, or widen the range in the "
                    "ontology"
                )
        elif kind in TYPED_KINDS:
            problem = typed_problem(value)  # type: ignore[arg-type]
            if problem:
                raise PropertyValueError(f"{where}property '{info.name}': {problem}")

    def check_property(self, cls: str, name: str, value: Value) -> None:
        """:meth:`check_value`, and the property's domain must admit an element of ``cls``."""
        info = self.data_property(name)
        up = self._up(cls)
        if info.domains and up.isdisjoint(info.domains):
            raise PropertyValueError(
                f"property '{name}' does not apply to {with_article(cls)}: "
                f"it is for {one_of(info.domains)}"
            )
        self.check_value(name, value)

    # ----------------------------------------------------------------------- templates

    @property
    def templates(self) -> Mapping[str, TemplateDef]:
        return MappingProxyType(self._decl.templates)

    def template(self, name: str) -> TemplateDef:
        """A template by name, or the default template of a class (``template("KitBox")``).
        Returns a copy: change its properties freely."""
        key = name if name in self._decl.templates else self._tpl_by_class.get(name)
        if key is None:
            if name in self._ancestors:
                several = sorted(t.name for t in self._decl.templates.values() if t.type == name)
                detail = f"several, ask by name: {several}" if several else "none defined"
                raise UnknownTemplateError(f"no default template for class {name!r} ({detail})")
            hint = did_you_mean(name, [*self._decl.templates, *self._tpl_by_class])
            raise UnknownTemplateError(f"unknown template {name!r}{hint}")
        t = self._decl.templates[key]
        props = {k: list(v) if isinstance(v, list) else v for k, v in t.properties.items()}
        return TemplateDef(name=t.name, type=t.type, label=t.label, properties=props)

    def _check_template(self, t: TemplateDef) -> None:
        self.check_class(t.type)
        for key, value in t.properties.items():
            self.check_property(t.type, key, value)
