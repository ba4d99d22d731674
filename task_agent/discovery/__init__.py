"""Discovery: the agents the task layer may use, their robots, devices and skills.

- :func:`agents_from_view` reads the agents' registrations in the world model into
  :class:`AgentInfo` values (pure: no Zenoh); a skill whose description cannot be read is
  left out and the reason recorded in ``AgentInfo.problems``.
- :class:`Discovery` keeps them current: the registrations from the local world-model replica,
  and the agents' liveliness tokens (an agent whose token disappears is unavailable at once).
  Agents of class :data:`OPERATOR_CLASS` (a person answering skills) are never offered to the
  planner.

The code: ``_registrations`` (the world model's registrations) and ``_liveliness``
(:class:`Discovery`, its Zenoh adapter).
"""

from ._liveliness import OPERATOR_CLASS as OPERATOR_CLASS
from ._liveliness import Discovery as Discovery
from ._liveliness import PresenceCallback as PresenceCallback
from ._registrations import AgentInfo as AgentInfo
from ._registrations import agents_from_view as agents_from_view
from ._registrations import decode_description as decode_description

__all__ = [
    "OPERATOR_CLASS",
    "AgentInfo",
    "Discovery",
    "PresenceCallback",
    "agents_from_view",
    "decode_description",
]
