"""Data flow: the value ``@<step id>.<param>`` passes to a parameter: the step exists, is a call
that runs before this one in sequence order (not itself, not a parallel sibling), has that
parameter, of a type that fits, and a predicted value."""

from __future__ import annotations

from skill_agent import WorldView
from skill_agent.parameters import is_value_kind
from skill_agent.protocol import ParamSpec
from wm_store.ontology import did_you_mean, with_article
from wm_store.protocol import Value

from ..protocol import Call
from ..taskfile import CallSite, Ref, precedes
from ._attempt import REF_FORM, Attempt, Earlier

__all__ = ["flow"]

_SIZES = frozenset({"SizeCuboid", "SizeCylinder", "SizeSphere"})


def flow(
    earlier: Earlier, site: CallSite, spec: ParamSpec, ref: Ref, view: WorldView, att: Attempt
) -> Value:
    """The value ``ref`` passes to ``spec`` (unchecked), or None (problem or blocked)."""
    text = f"parameter '{spec.name}' = '@{ref.step}.{ref.param}'"
    if not ref.param:
        att.fail(
            "dataflow",
            f"parameter '{spec.name}': '@{ref.step}' is not a reference; write {REF_FORM}",
        )
        return None
    why = _order(earlier, site, ref)
    if why:
        att.fail("dataflow", f"{text}: {why}")
        return None
    path = earlier.ids[ref.step][0].path
    desc = earlier.descs.get(path)
    if desc is None:
        att.blocked = True
        return None
    source = next((p for p in desc.parameters if p.name == ref.param), None)
    if source is None:
        hint = did_you_mean(ref.param, [p.name for p in desc.parameters])
        att.fail(
            "dataflow",
            f"{text}: step '{ref.step}' (skill {desc.name}) has no parameter '{ref.param}'{hint}",
        )
        return None
    if not _compatible(source, spec, text, att, view):
        return None
    params = earlier.params.get(path)
    if params is None:
        att.blocked = True
        return None
    value = params.get(ref.param)
    if value is None:
        att.fail(
            "dataflow",
            f"{text}: step '{ref.step}' runs without '{ref.param}' "
            "(optional and not given), so no value flows",
        )
    return value


def _order(earlier: Earlier, site: CallSite, ref: Ref) -> str:
    """Why step ``ref.step`` cannot pass values to ``site`` ("" if it can)."""
    sources = earlier.ids.get(ref.step, ())
    if not sources:
        ids = [c.call.id for c in earlier.calls.values()]
        return f"there is no step '{ref.step}'{did_you_mean(ref.step, ids)}"
    src = sources[0]
    if not isinstance(src.block, Call):
        return f"'{ref.step}' is a {type(src.block).__name__.lower()} block, not a call"
    if src.path == site.path:
        return "a step cannot take a value from itself"
    if src.path in site.parallel:
        return (
            f"step '{ref.step}' may run at the same time as this one (a parallel "
            "branch), so its values are not known when this step starts; order it "
            "before this step in a sequence"
        )
    if not precedes(earlier.calls[src.path], site):
        return f"step '{ref.step}' runs after this one; only earlier steps' values are known"
    return ""


def _compatible(src: ParamSpec, dst: ParamSpec, text: str, att: Attempt, view: WorldView) -> bool:
    """Whether ``src``'s values can fit ``dst``; a narrower target class is a warning."""
    s_value, d_value = is_value_kind(src.type), is_value_kind(dst.type)
    if s_value and d_value:
        fits = src.type == dst.type or {src.type, dst.type} <= {"str", "string"}
        fits = fits or dst.type == "any" or (src.type, dst.type) == ("int", "float")
        fits = fits or (dst.type == "Size" and src.type in _SIZES)
    elif not s_value and not d_value:
        onto = view.ontology
        if onto.is_a(src.type, dst.type):
            return True
        fits = onto.is_a(dst.type, src.type)
        if fits:
            att.warnings.append(
                (
                    "type",
                    f"{text}: the source is any {src.type}, "
                    f"'{dst.name}' takes {with_article(dst.type)} only; the "
                    "predicted value is checked, the one at run time may "
                    "differ",
                )
            )
    else:
        fits = False
    if not fits:
        att.fail(
            "type",
            f"{text}: the source is {with_article(src.type)}, '{dst.name}' "
            f"takes {with_article(dst.type)}",
        )
    return fits
