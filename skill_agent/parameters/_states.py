"""Parameter states: SkiROS's ``initialized -> specified`` (``protocol.ParamState``).

Every parameter of a skill starts ``initialized`` and becomes ``specified`` once it has a
value (given and checked, its default, a bound device, inferred): :func:`param_states` tells
them from a run's values (``RunInfo.param_states``). A start refused because parameters could
not all be specified (:class:`~skill_agent.UnspecifiedParameterError`,
:class:`~skill_agent.InferenceError`, built here for :func:`skill_agent.parameters.specify`)
carries every parameter's state in ``param_states`` and names those still ``initialized`` in
its message.
"""

from __future__ import annotations

from collections.abc import Mapping

from skill_agent._errors import InferenceError, UnspecifiedParameterError
from skill_agent.protocol._skills import ParamSpec, ParamState, SkillDescription
from wm_store.protocol import Value

__all__ = ["not_inferred_error", "param_states", "unspecified_error"]


def param_states(desc: SkillDescription, values: Mapping[str, Value]) -> dict[str, ParamState]:
    """Every parameter's state: ``specified`` if ``values`` gives it a value (not None), else
    ``initialized``."""
    return {
        p.name: "initialized" if values.get(p.name) is None else "specified"
        for p in desc.parameters
    }


def _states_note(desc: SkillDescription, states: Mapping[str, ParamState]) -> str:
    """`` (still initialized: a, b (optional); specified: c)``, for a refusal's message."""
    optional = {p.name for p in desc.parameters if p.optional}
    initialized = [
        f"{n} (optional)" if n in optional else n
        for n, state in states.items()
        if state == "initialized"
    ]
    specified = [n for n, state in states.items() if state == "specified"]
    return (
        f" (still initialized: {', '.join(initialized) or 'none'}; "
        f"specified: {', '.join(specified) or 'none'})"
    )


def unspecified_error(
    desc: SkillDescription, missing: list[ParamSpec], values: Mapping[str, Value]
) -> UnspecifiedParameterError:
    """UnspecifiedParameterError naming every parameter in ``missing`` and the states."""
    states = param_states(desc, values)
    names = ", ".join(f"'{p.name}' ({p.type})" for p in missing)
    if len(missing) == 1:
        head = f"parameter {names} of skill '{desc.name}' is required and has no default; "
        tail = "give it in the start request's params"
    else:
        head = f"parameters {names} of skill '{desc.name}' are required and have no default; "
        tail = "give them in the start request's params"
    return UnspecifiedParameterError(head + tail + _states_note(desc, states), param_states=states)


def not_inferred_error(
    exc: InferenceError, desc: SkillDescription, values: Mapping[str, Value]
) -> InferenceError:
    """``exc`` with the parameter states added (message and ``param_states``)."""
    states = param_states(desc, values)
    return InferenceError(f"{exc}{_states_note(desc, states)}", param_states=states)
