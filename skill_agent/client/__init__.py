"""Talking to skill agents from outside: calling their skills and reading their event logs.

:class:`AgentClient` starts a skill on an agent and waits for its result (or follows its
progress), :func:`list_agents` and :func:`find_skills` discover agents and their skills over the
mesh, and :class:`EventFeed` yields the entries of one agent's or every agent's event log.

Modules: ``_calls`` (AgentClient), ``_progress`` (following a run's progress: RunFeed),
``_discovery`` (list_agents, find_skills), ``_event_feed`` (EventFeed).
"""

from ._calls import AgentClient as AgentClient
from ._calls import new_run_id as new_run_id
from ._discovery import find_skills as find_skills
from ._discovery import list_agents as list_agents
from ._event_feed import EventFeed as EventFeed

__all__ = [
    "AgentClient",
    "EventFeed",
    "find_skills",
    "list_agents",
    "new_run_id",
]
