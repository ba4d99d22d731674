"""Skill parameters: :func:`specify` them for a run (load-time checks: ``_check``).

A parameter's ``type`` is a *value kind* (:data:`VALUE_KINDS`) or an ontology class (an
*element parameter*: its value is an element id). Value kinds: ``float`` (an int is accepted
and becomes a float), ``int`` and ``bool`` (a bool is not an int), ``str``/``string``,
``list``, ``any``, the typed values by struct name (``Pose``, ``Position``, ``Orientation``,
``Frame``, ``SizeCuboid``, ``SizeCylinder``, ``SizeSphere``, ``Color``) and ``Size`` (any
of the three sizes).

:func:`specify` turns the values of a start request into every parameter's value:

- a name the skill does not have -> UnknownParameterError naming the closest;
- a given value is checked: its kind (ParameterTypeError), or for an element parameter that
  the element exists (ParameterError listing the elements of the class), is of the class
  (subclasses fit) and matches the partial definition (ParameterTypeError), and for a
  hardware parameter, when ``robot`` is known, that it is a device of this agent;
- a missing value takes the parameter's ``default``; an ``optional`` one may stay None (an
  optional element parameter is not inferred); a required value parameter without default
  -> UnspecifiedParameterError naming every such parameter (never a crash later, SkiROS2 #91);
- a missing hardware parameter takes the device ``hardware[name]``, else this agent's device
  of that class (the ``hardware`` values and the robot's ``hasA`` parts; several -> the first
  by id, and the reason says so); an *optional* one takes ``hardware[name]``, else this
  agent's one device of that class, else stays None (several: None, it is optional; given
  as None: stays None);
- a hardware parameter the agent binds (``hardware[name]``, from its configuration) always
  gets that device: a request naming another device *of this agent* for it (a planner binds
  the robot's own camera, not knowing the agent's configuration) is answered with the bound
  device, and ``inferred`` says so; a device of another agent is still refused;
- a missing element parameter is inferred (:mod:`skill_agent.parameters`), afresh on every
  call; ``Specified.inferred`` holds the reason for each value chosen automatically.

Parameter states (SkiROS, :data:`~skill_agent.protocol.ParamState`): every parameter starts
``initialized`` and becomes ``specified`` once it has a value (given and checked, default,
bound device, inferred); :mod:`skill_agent.parameters` tells them. A start refused because
parameters could not all be specified (UnspecifiedParameterError, InferenceError) carries every
parameter's state in ``param_states`` and names the ones still ``initialized`` in its message.
"""

from __future__ import annotations

import difflib
from collections.abc import Iterable, Mapping
from types import MappingProxyType
from typing import Final

import msgspec

from skill_agent._errors import (
    InferenceError,
    ParameterError,
    ParameterTypeError,
    UnknownParameterError,
)
from skill_agent._skill import WorldView
from skill_agent.conditions._model import ConditionRegistry
from skill_agent.parameters._inference import describe_query, infer, matching
from skill_agent.parameters._states import not_inferred_error, param_states, unspecified_error
from skill_agent.protocol._skills import (
    ParamSpec,
    SkillDescription,
)
from wm_store import display_name
from wm_store.ontology import TYPED_KINDS, did_you_mean, kind_of, with_article
from wm_store.protocol import Value
from wm_store.scene import id_sort_key

__all__ = [
    "VALUE_KINDS",
    "Specified",
    "check_kind",
    "is_value_kind",
    "param_states",
    "specify",
]

_SIZES: Final = frozenset({"SizeCuboid", "SizeCylinder", "SizeSphere"})
VALUE_KINDS: Final = frozenset(
    {"float", "int", "bool", "str", "string", "list", "any", "Size", *TYPED_KINDS}
)
"""Parameter types that are values, not ontology classes."""
_NO_DEVICES: Final[Mapping[str, str]] = MappingProxyType({})


class Specified(msgspec.Struct, frozen=True):
    """Every parameter's value (None: an optional one left out), and why each inferred
    parameter got its value."""

    values: dict[str, Value]
    inferred: dict[str, str]


def _closest(name: str, pool: Iterable[str]) -> str:
    """`` (did you mean 'x'?)`` or ""."""
    hint = did_you_mean(name, pool)
    return "" if hint == "." else f" ({hint[2:]})"


def is_value_kind(type_name: str) -> bool:
    """True if a parameter of this type holds a value, False if it holds an element id."""
    return type_name in VALUE_KINDS


def check_kind(spec: ParamSpec, value: Value) -> Value:
    """``value`` if it fits the value kind of ``spec`` (an int becomes a float for ``float``),
    else ParameterTypeError."""
    t = spec.type
    kind = kind_of(value)
    if (
        t == "any"
        or (t == "list" and isinstance(value, list))
        or (t in ("str", "string") and kind == "string")
        or (t in ("bool", "int") and kind == t)
        or (t == "Size" and kind in _SIZES)
        or (t in TYPED_KINDS and kind == t)
    ):
        return value
    if t == "float" and kind in ("int", "float"):
        return float(value)  # type: ignore[arg-type]  # kind says int or float
    got = "a list" if isinstance(value, list) else f"{kind or type(value).__name__} {value!r}"
    raise ParameterTypeError(f"parameter '{spec.name}' takes {with_article(t)} value, got {got}")


def _check_element(
    desc: SkillDescription, spec: ParamSpec, value: Value, view: WorldView, devices: list[str]
) -> str:
    where = f"parameter '{spec.name}' of skill '{desc.name}'"
    if not isinstance(value, str):
        raise ParameterTypeError(
            f"{where} takes an element id ({with_article(spec.type)}), got {value!r}"
        )
    element = view.find_element(value)
    if element is None:
        known = [e.id for e in view.resolve_element(type=spec.type)]
        hint = did_you_mean(value, known)
        if hint == ".":  # no close name: the class's elements, the most alike first
            alike = sorted(known, key=lambda k: -difflib.SequenceMatcher(None, value, k).ratio())
            hint = f"; elements of class {spec.type}: {', '.join(alike[:10]) or 'none'}"
        raise ParameterError(f"{where}: no element {value!r} in the world model{hint}")
    ontology = view.ontology
    name = display_name(element)
    if not ontology.is_a(element.type, spec.type):
        chain = " < ".join(ontology.superclasses(element.type))
        raise ParameterTypeError(
            f"{where} takes {with_article(spec.type)}; {name} is {with_article(element.type)} "
            f"({chain})"
        )
    if spec.partial is not None and value not in matching(view, spec):
        raise ParameterTypeError(
            f"{where}: {name} does not match its partial definition "
            f"({describe_query(spec.partial)})"
        )
    if spec.kind == "hardware" and devices and value not in devices:  # devices: [] w/o robot
        mine = [d for d in devices if _is(view, d, spec.type)]
        raise ParameterError(
            f"{where}: {name} is not a device of this agent; its {spec.type} devices: "
            f"{_names(view, mine) or 'none'}"
        )
    return value


def _names(view: WorldView, element_ids: Iterable[str]) -> str:
    """Elements as messages name them (:func:`wm_store.display_name`), comma-separated."""
    return ", ".join(display_name(view.find_element(i), i) for i in element_ids)


def _is(view: WorldView, element_id: str, cls: str) -> bool:
    element = view.find_element(element_id)
    return element is not None and view.ontology.is_a(element.type, cls)


def _agent_devices(view: WorldView, hardware: Mapping[str, str], robot: str | None) -> list[str]:
    """The ``hardware`` values, ``robot`` and every part of it reached through ``hasA``."""
    found = set(hardware.values()) | ({robot} if robot else set())
    todo = [robot] if robot else []
    predicate = "hasA" if "hasA" in view.ontology.relations else "spatialRelation"
    while todo:
        for rel in view.query_relation(todo.pop(), predicate):
            if rel.object not in found:
                found.add(rel.object)
                todo.append(rel.object)
    return sorted(found, key=id_sort_key)


def _pick_device(
    desc: SkillDescription, spec: ParamSpec, view: WorldView, devices: list[str], robot: str | None
) -> tuple[str, str]:
    fitting = [d for d in devices if _is(view, d, spec.type)]
    if spec.partial is not None:
        allowed = set(matching(view, spec))
        fitting = [d for d in fitting if d in allowed]
    if not fitting:
        raise InferenceError(
            f"cannot choose hardware parameter '{spec.name}' ({with_article(spec.type)}) of "
            f"skill '{desc.name}': this agent offers no such device (its devices: "
            f"{', '.join(devices) or 'none'}; robot: {robot or 'not given'})"
        )
    first, second = _names(view, fitting[:1]), _names(view, fitting[1:2])
    if len(fitting) == 1:
        return fitting[0], f"{first}: this agent's only {spec.type}"
    return fitting[0], (
        f"{first}: first by id of this agent's {len(fitting)} {spec.type} devices "
        f"({_names(view, fitting)}); runner-up {second}; give '{spec.name}' to choose another"
    )


def _none(given: Mapping[str, Value], spec: ParamSpec) -> bool:
    """Whether the request sets ``spec`` to None on purpose (and it has no default)."""
    return spec.name in given and given[spec.name] is None and spec.default is None


def _hardware_value(
    desc: SkillDescription,
    spec: ParamSpec,
    value: Value,
    view: WorldView,
    hardware: Mapping[str, str],
    devices: list[str],
    robot: str | None,
) -> tuple[Value, str]:
    """The device of hardware parameter ``spec`` (given ``value`` or None) and, when the agent
    chose it, why (see the module doc)."""
    known = devices if robot else []  # ``hardware`` alone does not list every device
    bound = hardware.get(spec.name)
    if value is not None:
        checked = _check_element(desc, spec, value, view, known)
        if bound is None or bound == checked or checked not in devices:
            return checked, ""
        device = _check_element(desc, spec, bound, view, [])
        return device, (
            f"{_names(view, [device])}: this agent's '{spec.name}' device, bound by its "
            f"configuration ({_names(view, [checked])} was asked for)"
        )
    if bound is not None:
        device = _check_element(desc, spec, bound, view, [])
        return device, f"{_names(view, [device])}: this agent's '{spec.name}' device"
    if not spec.optional:
        return _pick_device(desc, spec, view, devices, robot)
    fitting = [d for d in devices if _is(view, d, spec.type)]
    if spec.partial is not None:
        allowed = set(matching(view, spec))
        fitting = [d for d in fitting if d in allowed]
    if len(fitting) == 1:
        return fitting[0], f"{_names(view, fitting)}: this agent's only {spec.type} (optional)"
    return None, ""


def specify(
    desc: SkillDescription,
    given: Mapping[str, Value],
    view: WorldView,
    *,
    hardware: Mapping[str, str] = _NO_DEVICES,
    robot: str | None = None,
    registry: ConditionRegistry | None = None,
) -> Specified:
    """Every parameter of ``desc`` specified for a run (see the module doc).

    ``hardware``: parameter name (or any key) -> device element id offered by this agent;
    ``robot``: the agent's robot element id (its pose ranks candidates by distance, its
    ``hasA`` parts are the agent's devices)."""
    names = [p.name for p in desc.parameters]
    unknown = sorted(set(given) - set(names))
    if unknown:
        hints = ", ".join(f"{n!r}{_closest(n, names)}" for n in unknown)
        raise UnknownParameterError(
            f"skill '{desc.name}' has no parameter {hints}. Its parameters: "
            f"{', '.join(names) or 'none'}"
        )
    devices = _agent_devices(view, hardware, robot)
    known_devices = devices if robot else []  # ``hardware`` alone does not list every device
    values: dict[str, Value] = {}
    inferred: dict[str, str] = {}
    pending: list[ParamSpec] = []  # element parameters to infer
    missing: list[ParamSpec] = []  # required value parameters without a value
    no_device: list[InferenceError] = []
    for spec in desc.parameters:
        value = given.get(spec.name)
        value = spec.default if value is None else value
        element = not is_value_kind(spec.type)
        values[spec.name] = None  # initialized until a value is found below
        if element and spec.kind == "hardware" and not (spec.optional and _none(given, spec)):
            try:
                device, why = _hardware_value(desc, spec, value, view, hardware, devices, robot)
            except InferenceError as exc:
                no_device.append(exc)
                continue
            values[spec.name] = device
            if why:
                inferred[spec.name] = why
        elif value is not None and element:
            values[spec.name] = _check_element(desc, spec, value, view, known_devices)
        elif value is not None:
            values[spec.name] = check_kind(spec, value)
        elif spec.optional:
            pass
        elif not element:
            missing.append(spec)
        else:
            pending.append(spec)
    if missing:
        raise unspecified_error(desc, missing, values)
    if no_device:
        raise not_inferred_error(no_device[0], desc, values)
    if pending:
        try:
            chosen, reasons = infer(desc, view, values, pending, robot=robot, registry=registry)
        except InferenceError as exc:
            raise not_inferred_error(exc, desc, values) from None
        values.update(chosen)
        inferred.update(reasons)
    return Specified(values=values, inferred=inferred)


# --------------------------------------------------------------------------- load checks
