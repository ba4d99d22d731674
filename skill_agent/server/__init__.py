"""``skimesh agent``: a skill agent served over Zenoh.

This package is the skill layer's Zenoh adapter (the runtime itself, :class:`AgentCore`, knows
no network). For an agent ``<a>`` (keys under ``skimesh/<mesh>``):

- ``agents/<a>/skills``  queryable: :class:`~skill_agent.protocol.SkillsReply` to an empty
  payload or an encoded :class:`~skill_agent.protocol.ListSkills`; another request gets an
  error reply ``bad_request`` (:attr:`AgentService.skills`);
- ``agents/<a>/rpc``     queryable: one :data:`AgentRequest` -> one :data:`AgentReply`; every
  refusal is a Zenoh *error reply* carrying an :class:`ErrorReply` (``code`` = the error class's
  code, so the client re-raises the same class) (:attr:`AgentService.rpc`);
- on both queryables (each a :class:`meshlink.rpc.RequestHandler`), bytes that are no request
  (undecodable, invalid UTF-8, nested too deeply, an unknown tag, a wrong field type) answer
  ``bad_request``, a request over the layer's size limit ``too_large``, an unexpected
  exception ``internal``: no request crashes the agent or changes state;
- ``agents/<a>/runs/<run>/progress``  publication (BLOCK): every :data:`RunEvent` of the run,
  in order, ending with its :class:`RunResult`; progress events may wait up to 2 ms to go out
  in a burst, a result goes at once (:class:`RunEventPublisher`);
- ``agents/<a>/events``  publication (BLOCK): every :data:`~skill_agent.protocol.LogEntry` of
  the agent's event log (runs started, progress, results, refused starts, world-model writes),
  in order, through the same publisher (queued on the loop, sent in the same bursts; a run's
  entries go out before its result on the progress key);
- the agent keeps its recent runs' events (:class:`RunHistory`: at most 500 per run, of the
  last 256 ended runs and every running one), answered to ``RunEvents`` (a run's state and
  history: ``skimesh runs AGENT RUN``);
- ``agents/<a>``  liveliness token, declared once the queryables are up, so whoever sees the
  agent alive can call it.

Start-up order: core running -> queryables -> token -> registration in the world model (agent,
robot, devices, skills: :meth:`WmClient.register_robot`; the presence monitor of the store then
keeps ``available`` equal to the token) -> wiring: the drivers given (by label: in-process
drivers of a simulated world, or Zenoh proxies from
:func:`~device_drivers.remote.connect_devices`) are bound to the elements of the
registered robot and devices, and the configuration's ``[hardware]`` bindings to theirs
(:mod:`skill_agent.runtime`). Stop (cancellation): every run is preempted and its result
published, then, shielded, the agent unregisters and the token is undeclared.
"""

from ._history import RunHistory as RunHistory
from ._publisher import RunEventPublisher as RunEventPublisher
from ._service import AgentService as AgentService
from ._serving import FindDevices as FindDevices
from ._serving import agent_registration as agent_registration
from ._serving import run_agent as run_agent
from ._serving import serve_agent as serve_agent
from ._serving import simulated_outcomes as simulated_outcomes

__all__ = [
    "AgentService",
    "FindDevices",
    "RunEventPublisher",
    "RunHistory",
    "agent_registration",
    "run_agent",
    "serve_agent",
    "simulated_outcomes",
]
