"""Verification: offline checks of hand-written task structures (FRIEND II): :func:`verify` finds,
before anything runs, every reason a task file would fail for its structure, names, data flow,
types, resources or pre-conditions. Pure and synchronous; problems come in document order
(a block before its children; per block: structure, unknown, dataflow, type, resource,
precondition).

Checks (``VerifyProblem.kind``)::

    structure     an empty sequence / parallel block; an id used by several blocks; a call
                  without a skill
    unknown       an unknown agent, a skill the agent lacks, a skill no agent offers, a
                  parameter the skill lacks (each with the closest names)
    dataflow      a required parameter with no value when its step starts: value parameters
                  need a literal, a default or '@step.param'; element parameters left out are
                  inferred at run time, accepted when the world model holds a candidate then;
                  '@step.param' must name an earlier step in sequence order (not a parallel
                  sibling, not a later step, not itself) that has that parameter
    type          a literal of the wrong kind; an element id (or 'label:') that names no
                  element, several, one of the wrong class or outside the partial definition,
                  a device of another agent; '@step.param' between incompatible types
    resource      two calls that may run at the same time lock the same device (the agent
                  would refuse the second start), or use one agent whose devices for them are
                  not known, or send two robots to a place that holds one robot (its
                  ``robotCapacity``: the second would wait at run time)
    precondition  a pre- or hold-condition false when its step starts, in the symbolic
                  simulation, or made false by a parallel branch's effects (which may come
                  first or meanwhile); no candidate satisfying the pre-conditions for an
                  inferred parameter; predicted effects that cannot be committed; parallel
                  branches changing the same fact differently

**Symbolic simulation.** From a private copy of the world model, each step in execution order
is specified as its agent would (``_call``), its pre- and hold-conditions
evaluated, then the effects of its post-conditions applied
(:func:`wm_store.scene.apply_transaction`), also after a false condition, so one
mistake is reported once. Each branch of a parallel block starts from the state before the
block plus its own effects; then every branch's effects are applied, in branch order. Two
branches changing one fact differently are reported (``_scene``), and so is
a call whose pre- or hold-condition turns false when a sibling branch's effects, after any of
its steps, are applied to the state the call starts in. Steps
whose agent or skill is unknown change nothing. Sensing is not simulated: a post-condition no
effect makes true (``has object.pose``) is assumed, objects do not move in ``pre_sense``.

**Agent-less calls.** The task agent runs a call that names no agent on the first idle agent
offering the skill (by name). The call is checked on every agent it may get: the first one,
and the next ones while a call that may run at the same time could occupy the previous one;
it must work on each. The first agent it works on is the one simulated.

**Resources.** A call locks the devices bound to its hardware parameters: those given (or
passed by data flow), and those its agent binds at run time (the agent's first device of the
class) when the agent is certain; the agent as a whole when it has no fitting device. A call
that may get one of several agents locks the devices it names only.

:func:`check` returns a :class:`Report`: the problems, and warnings (a parallel block with one
child; a data-flow source whose class is broader than the target's; a custom condition left to
run time) and notes (what each inferred parameter will be) that do not fail the task, with
the predicted steps and final world model. A task with no problems does not fail for these
reasons at run time as long as the world model evolves as predicted.

The code: ``_verify`` (:func:`check`, :func:`verify`: the walk over the blocks and the
symbolic simulation), ``_call`` (one call when its step starts: its agents, parameters and
conditions), ``_values`` (a given value: kind, element, device), ``_dataflow`` (a value passed
by ``@step.param``), ``_resources`` (the devices calls lock), ``_attempt`` (what one attempt
found, what earlier steps left) and ``_scene`` (the private world model copy,
:class:`SceneView`, and what parallel branches change in it).
"""

from ._scene import SceneView as SceneView
from ._verify import Level as Level
from ._verify import Report as Report
from ._verify import StepPrediction as StepPrediction
from ._verify import check as check
from ._verify import verify as verify

__all__ = ["Level", "Report", "SceneView", "StepPrediction", "check", "verify"]
