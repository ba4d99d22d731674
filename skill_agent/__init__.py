"""skimesh skill layer: the skill model, the async skill agent runtime and its Zenoh adapter.

The top level is what a skill writer imports: the implementation contract (:class:`Skill`,
:class:`SkillContext`, :class:`WorldView`), composite skills (:class:`CompositeSkill` and its
nodes) and the error tree (every exception of the package derives from :class:`SkillError`).
The concepts are sub-packages whose faces are their public paths (pure core first, adapters
last)::

    protocol      wire schema: skill descriptions, conditions, runs, requests, event-log entries
    conditions    evaluation against the world model, predicted effects, planner atoms
    parameters    specification of a run's parameters, their states, inference, load checks
    runtime       AgentCore and one run's lifecycle, device locks, the event log, simulated
                  outcomes, agent config (TOML), skill plug-ins, wiring drivers to elements
    server        Zenoh: serve an agent (``skimesh agent``)
    client        Zenoh: call an agent's skills, read agents' event logs
    external      Zenoh: a skill that drives an external goal / feedback / cancel service
    primitives    motion primitives and grasp planning over the device interfaces
    skills        the standard skill library (one module per skill family, ``module:Class``)

Write a skill: docs/guides/write-a-skill.md.

The face imports its errors; the skill contract and composite skills load on first use (PEP 562
``__getattr__``), so a command line that only reports errors starts fast.
"""

from __future__ import annotations

import importlib
from typing import TYPE_CHECKING, Any

from ._errors import AgentInternalError as AgentInternalError
from ._errors import AgentTransportError as AgentTransportError
from ._errors import BadRequestError as BadRequestError
from ._errors import InferenceError as InferenceError
from ._errors import ParameterError as ParameterError
from ._errors import ParameterTypeError as ParameterTypeError
from ._errors import PreconditionError as PreconditionError
from ._errors import RemoteSkillError as RemoteSkillError
from ._errors import ResourceBusyError as ResourceBusyError
from ._errors import RunStateError as RunStateError
from ._errors import SkillError as SkillError
from ._errors import SkillFailure as SkillFailure
from ._errors import SkillLoadError as SkillLoadError
from ._errors import UnknownParameterError as UnknownParameterError
from ._errors import UnknownRunError as UnknownRunError
from ._errors import UnknownSkillError as UnknownSkillError
from ._errors import UnspecifiedParameterError as UnspecifiedParameterError

if TYPE_CHECKING:
    from ._composite import CompositeSkill as CompositeSkill
    from ._composite import Node as Node
    from ._composite import Parallel as Parallel
    from ._composite import Retry as Retry
    from ._composite import Selector as Selector
    from ._composite import Sequence as Sequence
    from ._composite import Step as Step
    from ._composite import check_composite as check_composite
    from ._skill import Skill as Skill
    from ._skill import SkillContext as SkillContext
    from ._skill import WorldView as WorldView

#: The names imported on first use (PEP 562), and their modules.
_LAZY: dict[str, str] = {
    "CompositeSkill": "._composite",
    "Node": "._composite",
    "Parallel": "._composite",
    "Retry": "._composite",
    "Selector": "._composite",
    "Sequence": "._composite",
    "Step": "._composite",
    "check_composite": "._composite",
    "Skill": "._skill",
    "SkillContext": "._skill",
    "WorldView": "._skill",
}


def __getattr__(name: str) -> Any:
    if name not in _LAZY:
        raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
    globals()[name] = value = getattr(importlib.import_module(_LAZY[name], __name__), name)
    return value


__all__ = [
    "AgentInternalError",
    "AgentTransportError",
    "BadRequestError",
    "CompositeSkill",
    "InferenceError",
    "Node",
    "Parallel",
    "ParameterError",
    "ParameterTypeError",
    "PreconditionError",
    "RemoteSkillError",
    "ResourceBusyError",
    "Retry",
    "RunStateError",
    "Selector",
    "Sequence",
    "Skill",
    "SkillContext",
    "SkillError",
    "SkillFailure",
    "SkillLoadError",
    "Step",
    "UnknownParameterError",
    "UnknownRunError",
    "UnknownSkillError",
    "UnspecifiedParameterError",
    "WorldView",
    "check_composite",
]
