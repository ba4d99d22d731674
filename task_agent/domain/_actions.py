"""Planning actions from skill drafts: preconditions and effects, with what is implicit.

:func:`action_schema` turns one ``_skills.Draft`` into an
:class:`~task_agent.domain.ActionSchema` over the task's ``_vocabulary.Vocabulary``: pre- and
hold-condition atoms become preconditions (``empty`` ones negated existentials), post-condition
atoms effects, plus what the world model does implicitly (re-parenting on a spatial relation,
super- and sub-properties, one value per property, derived ``empty``). The rules are under
**Conditions** in :mod:`task_agent.domain`.
"""

from __future__ import annotations

from skill_agent.parameters import bindings

from ._model import ROOT_TYPE, ActionSchema, ForallDelete, Lit
from ._skills import Draft
from ._vocabulary import Vocabulary

__all__ = ["action_schema"]


def _class(vocab: Vocabulary, d: Draft, arg: str) -> str:
    if arg.startswith("?"):
        return d.variables[arg[1:]]
    element = vocab.view.find_element(arg)
    return element.type if element is not None else ROOT_TYPE


def action_schema(vocab: Vocabulary, d: Draft, name: str) -> ActionSchema:
    """The action ``name`` of draft ``d`` (``vocab``'s predicates and types are known)."""

    def arg(p: str) -> str:
        return d.bound.get(p) or f"?{p}"

    params: list[tuple[str, str]] = []
    pre: dict[Lit, None] = {}
    for var, cls in d.variables.items():
        if cls in vocab.conflicts:
            params.append((var, ROOT_TYPE))
            pre[Lit(f"is_{cls}", (f"?{var}",))] = None
        else:
            params.append((var, cls))
    for var in d.owned:
        pre[Lit("owns", (d.agent.robot or "", f"?{var}"))] = None
    empty_pre: list[tuple[tuple[str, ...], str, bool]] = []
    for atom in d.pre:
        kind, subject = vocab.names.kind(atom.predicate)
        args = tuple(arg(a) for a in atom.args)
        if kind == "empty":
            empty_pre.append((tuple(vocab.subs(subject)), args[0], atom.positive))
        else:
            pre[Lit(atom.predicate, args, atom.positive)] = None
    add: dict[Lit, None] = {}
    delete: dict[Lit, None] = {}
    forall: dict[ForallDelete, None] = {}
    spatial = vocab.spatial()
    held = [lit for lit in pre if lit.positive and lit.pred in spatial]
    for atom in d.post:
        kind, subject = vocab.names.kind(atom.predicate)
        args = tuple(arg(a) for a in atom.args)
        if kind == "relation" and atom.positive:
            if vocab.onto.relation(subject).spatial:
                # The tree has one spatial parent per element: when a precondition names
                # it, delete that fact; otherwise whichever parent there is.
                parents = {lit.args[0] for lit in held if lit.args[1] == args[1]}
                for r in spatial:
                    for parent in parents:
                        delete[Lit(r, (parent, args[1]), False)] = None
                    if not parents:
                        forall[ForallDelete(r, r, args[1], 0)] = None
            for r in (subject, *vocab.supers(subject)):
                add[Lit(r, args)] = None
        elif kind == "relation":
            for r in {*vocab.subs(subject), *vocab.supers(subject)}:
                delete[Lit(r, args, False)] = None
        elif kind == "value" and atom.positive:
            add[Lit(atom.predicate, args)] = None
            for other in vocab.values[subject] - {atom.predicate}:
                delete[Lit(other, args, False)] = None
            if subject in vocab.has:
                add[Lit(f"has_{subject}", args)] = None
        elif kind == "has" and not atom.positive:
            for other in (atom.predicate, *sorted(vocab.values.get(subject, ()))):
                delete[Lit(other, args, False)] = None
        elif kind == "empty" and atom.positive:
            subs = vocab.subs(subject)
            cls = _class(vocab, d, args[0])
            single = cls != ROOT_TYPE and vocab.onto.max_cardinality(cls, subject) == 1
            items = {
                lit.args[1]
                for lit in pre
                if lit.positive and lit.pred in subs and lit.args[0] == args[0]
            }
            for sub in subs:
                for r in (sub, *vocab.supers(sub)):
                    if single and items:  # it holds one thing at most: the one named
                        for item in items:
                            delete[Lit(r, (args[0], item), False)] = None
                    else:
                        forall[ForallDelete(sub, r, args[0], 1)] = None
        elif kind in ("value", "has", "opaque"):
            (add if atom.positive else delete)[Lit(atom.predicate, args, atom.positive)] = None
        # type atoms are static and negated empties are implied: no effect
    return ActionSchema(
        name=name,
        agent=d.agent.name,
        skill=d.desc.name,
        family=d.desc.family,
        duration=d.desc.duration,
        params=tuple(params),
        bound=dict(d.bound),
        pre=tuple(pre),
        empty_pre=tuple(empty_pre),
        add=tuple(add),
        delete=tuple(delete),
        forall_delete=tuple(forall),
        runtime_only=tuple(d.runtime_only),
        shared=tuple(v for v in bindings(d.desc).values() if v not in d.agent.hardware),
    )
