"""Conditions of skills: evaluation against the world model, predicted effects, planner atoms.

A condition (``skill_agent.protocol.Condition``) is data with four faces:

``evaluate(cond, view, bindings)``
    Run time: a :class:`Verdict` (``ok`` and a reason a person understands, for true *and*
    false). Relation predicates include their sub-properties (``spatialRelation`` matches
    ``contain`` and ``hasA``). Leaf conditions presuppose their elements: a leaf whose parameter
    is unbound, not an element id, or names an element missing from the world model is false
    (also with ``holds=False``); only ``NotCond`` turns that into true, so prefer
    ``holds=False`` when "the box exists and does not contain the gear" is meant. A condition
    naming a class, relation or property the view's ontology lacks is false with the
    ontology's message (:func:`skill_agent.parameters.check_description` rejects it at load).
    Property comparisons: ``eq None`` means "absent", a missing property is ``ne`` anything
    else, ``lt``..``ge`` compare two numbers or two strings (a bool is not a number: never
    ``True == 1``), ``near`` two numbers or two positions/poses in the same frame. ``full``
    counts against the ``capacity`` property, else the ontology's maximum cardinality (a
    Gripper holds one thing), else the container is never full.
``effects(conds, view, bindings)``
    The prediction: world-model ops making post-conditions true, without ops for facts that
    already hold. ``RelationCond`` -> ``SetRelation`` (a spatial predicate first unsets the
    object's current spatial parent) or, with ``holds=False``, ``UnsetRelation`` of every
    matching relation (sub-properties included); ``PropertyCond`` ``eq`` -> ``UpdateElement``
    (``eq None`` deletes the property); ``AndCond`` -> its items; ``NotCond`` of a relation ->
    the opposite relation effect. Everything else is checked only. Later conditions win over
    earlier contradicting ones; unsets come first in the list, then sets, then updates.
``symbolic(cond)``
    The planner's view: a conjunction of :class:`Atom` over *parameter names*, or ``None``
    when the condition is run-time only. The task layer turns these into PDDL:

    ========================================  =========================================
    condition                                 atoms
    ========================================  =========================================
    RelationCond(s, p, o, holds)              ``p(s, o)``, positive = holds
    PropertyCond(x, q, eq, v) v bool/int/str  ``q=v(x)`` (bools as true/false)
    PropertyCond(x, q, ne, v) v bool/int/str  ``q=v(x)`` negative
    PropertyCond(x, q, exists)                ``has_q(x)``
    PropertyCond lt/le/gt/ge/near, float v    None (numeric: run time only)
    HasPropertyCond(x, q, holds)              ``has_q(x)``, positive = holds
    IsTypeCond(x, C)                          ``is_C(x)`` (static; subclasses count)
    EmptyCond(x, p, holds)                    ``empty_p(x)``, positive = holds (derived:
                                              no ``p(x, ?o)``)
    EmptyCond(..., full=True)                 None (needs counting)
    IsSpecifiedCond(x)                        [] (the planner binds every parameter)
    CustomCond(name, ...)                     the registered class's ``symbolic``, or None
    AndCond(items)                            all items' atoms; None if any item is None
    OrCond(items)                             one item: its atoms; else None
    NotCond(item)                             the item's single atom negated; else None
    ========================================  =========================================
``parameters_of(cond)``
    The parameter names a condition refers to (what inference and load checks use).

Custom conditions are classes registered by name in a :class:`ConditionRegistry`, one per
agent (no process-global registry). Everything here is pure and synchronous.

This package's face is the public entry point; the code lives in three private modules:
``_model`` (verdicts, atoms, the registry, ``describe``, ``parameters_of``, ``symbolic`` and
``value_text``), ``_eval`` (``evaluate``) and ``_effects`` (``effects``).
"""

from __future__ import annotations

from ._effects import effects as effects
from ._eval import evaluate as evaluate
from ._eval import evaluate_all as evaluate_all
from ._model import Atom as Atom
from ._model import Bindings as Bindings
from ._model import ConditionRegistry as ConditionRegistry
from ._model import CustomCondition as CustomCondition
from ._model import Verdict as Verdict
from ._model import describe as describe
from ._model import parameters_of as parameters_of
from ._model import symbolic as symbolic
from ._model import value_text as value_text

__all__ = [
    "Atom",
    "Bindings",
    "ConditionRegistry",
    "CustomCondition",
    "Verdict",
    "describe",
    "effects",
    "evaluate",
    "evaluate_all",
    "parameters_of",
    "symbolic",
    "value_text",
]
