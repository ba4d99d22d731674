"""The operator agent (semi-autonomy, FRIEND II): a skill agent whose skills a person answers.

When a step fails and its call (``Call.fallback_operator``) or its task
(``TaskOptions.operator_fallback`` for every skill, ``operator_fallback_skills`` for some)
allows it, the executor runs the same skill, with the parameters the failed run had, on this
agent. The run is an ordinary skill run (pre-conditions
checked, progress published, stop and time-out honoured); its ``execute`` opens a *pending
request* and waits until a person answers it with ``skimesh operator``: success commits the
skill's predicted effects to the world model (the person did the step), failure fails the run.

- :class:`OperatorDesk` keeps the pending requests (pure);
- :class:`OperatorSkill` is the implementation behind every skill of the agent;
- :class:`SkillMirror` gives the agent the skills of the robot agents registered in the world
  model (their descriptions, plus an ``operator_note`` text parameter and no time limit),
  kept current as agents register;
- :func:`serve_operator` serves it: ``agents/<name>/{rpc,skills}``, the run progress, the
  liveliness token ``agents/<name>``, an ``Operator`` element in the world model (no robot,
  no skill elements: the planner never plans for a person) and ``operator/rpc``
  (:class:`~task_agent.protocol.ListPending`, :class:`~task_agent.protocol.AnswerPending`).
- :func:`sighting_ops` turns what a person saw (:class:`~task_agent.protocol.SeenAt`) into
  world-model observations (the user as a sensor).

The code: ``_agent`` (the desk, the skill, the mirror, the service) and ``_sightings``.
"""

from ._agent import Answered as Answered
from ._agent import OperatorDesk as OperatorDesk
from ._agent import OperatorService as OperatorService
from ._agent import OperatorSkill as OperatorSkill
from ._agent import SkillMirror as SkillMirror
from ._agent import serve_operator as serve_operator
from ._sightings import sighting_ops as sighting_ops

__all__ = [
    "Answered",
    "OperatorDesk",
    "OperatorService",
    "OperatorSkill",
    "SkillMirror",
    "serve_operator",
    "sighting_ops",
]
