"""Offline verification of hand-written task structures (FRIEND II): :func:`verify` finds,
before anything runs, every reason a task file would fail for its structure, names, data flow,
types, resources or pre-conditions. Pure and synchronous; problems come in document order.

Checks (``VerifyProblem.kind``)::

    structure     an empty sequence / parallel block; an id used by several blocks
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
                  would refuse the second), or use one agent whose devices are not known
    precondition  a pre- or hold-condition false when its step starts, in the symbolic
                  simulation; no candidate satisfying the pre-conditions for an inferred
                  parameter; predicted effects that cannot be committed; parallel branches
                  changing the same fact differently

**Symbolic simulation.** From a private copy of the world model, each step in execution order
is specified like the agent does (:func:`skill_agent.params.specify`: defaults, devices,
inference), its pre- and hold-conditions evaluated, then the effects of its post-conditions
applied (:func:`wm_store.transactions.apply_transaction`), also when a condition was false (so
one mistake is reported once). Each branch of a parallel block starts from the state before
the block; then every branch's effects are applied in branch order. Steps whose agent or skill
is unknown change nothing. Sensing is not simulated (a post-condition no effect makes true,
such as ``has object.pose``, is assumed; pre-sensing that moves objects is not predicted).

:func:`check` returns a :class:`Report` with the problems and also warnings (a parallel block
with one child; a data-flow source whose class is broader than the target's; a custom
condition left to run time), notes (what each inferred parameter will be) and the predicted
steps and final world model. A task with no problems does not fail for these reasons at run
time as long as the world model evolves as predicted.
"""

