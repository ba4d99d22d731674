"""Skill parameters: specified for a run, checked at load, inferred when left out.

:func:`specify` turns a start request's values into a run's parameters (value kinds, element
classes, defaults, the agent's devices for hardware parameters, inference of the rest) and
:func:`check_description` checks a description against the ontology when a skill is loaded.
:func:`param_states` tells SkiROS's ``initialized`` / ``specified`` states from a run's values.
Inference (:func:`matching`, :func:`describe_query`, :func:`world_position`) ranks the
candidates of an unspecified element parameter. :func:`with_bindings` / :func:`bindings`
publish an agent's configured device bindings with its descriptions and read them back, so a
planner binds a hardware parameter to the device the run will lock.

Modules: ``_specify`` (value kinds, specification), ``_bindings`` (published device bindings),
``_check`` (load-time checks), ``_states``
(parameter states and the errors that carry them), ``_inference`` (candidates, ranking,
search).
"""

from ._bindings import bindings as bindings
from ._bindings import with_bindings as with_bindings
from ._check import check_description as check_description
from ._inference import describe_query as describe_query
from ._inference import matching as matching
from ._inference import world_position as world_position
from ._specify import VALUE_KINDS as VALUE_KINDS
from ._specify import Specified as Specified
from ._specify import check_kind as check_kind
from ._specify import is_value_kind as is_value_kind
from ._specify import specify as specify
from ._states import param_states as param_states

__all__ = [
    "VALUE_KINDS",
    "Specified",
    "bindings",
    "check_description",
    "check_kind",
    "describe_query",
    "is_value_kind",
    "matching",
    "param_states",
    "specify",
    "with_bindings",
    "world_position",
]
