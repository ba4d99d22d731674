"""The sorted numeric indexes behind range filters: same answers as the plain filter, kept
current through puts, removals, undo, type changes and classes defined at run time."""

from __future__ import annotations

import math
import operator
from collections.abc import Callable
from typing import Any

import anyio
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from wm_store import ValidationError
from wm_store.ontology import Ontology
from wm_store.protocol import (
    AddElement,
    ClassDef,
    ClassDefined,
    DefineClass,
    Element,
    PropertyFilter,
    Query,
    RemoveElement,
    Transact,
    UpdateElement,
    Value,
)
from wm_store.scene import SceneState, Undo, id_sort_key, resolve
from wm_store.server import WmStore

BASE = Ontology.default()
RUNTIME = (ClassDef(name="Widget", parent="Part"), ClassDef(name="MiniWidget", parent="Widget"))
ONTOLOGIES = [BASE, BASE.extend(classes=RUNTIME[:1]), BASE.extend(classes=RUNTIME)]
TYPES = ["Gear", "Shaft", "Part", "Box", "Widget", "MiniWidget"]
PROPS = ["mass", "capacity"]
OPS: dict[str, Callable[[Any, Any], bool]] = {
    "lt": operator.lt,
    "le": operator.le,
    "gt": operator.gt,
    "ge": operator.ge,
}
BIG = 2**53  # where int and float stop agreeing: comparisons must stay exact


def reference(ontology: Ontology, state: SceneState, query: Query) -> list[str]:
    """The plain filter, written out: every element, every filter."""
    types = {query.type} if query.exact_type else ontology.subclasses(query.type)

    def passes(e: Element, f: PropertyFilter) -> bool:
        have = e.properties.get(f.property)
        if f.op == "exists":
            return f.property in e.properties
        if f.op == "eq":
            return f.property in e.properties and have == f.value
        assert isinstance(f.value, int | float)
        return type(have) in (int, float) and OPS[f.op](have, float(f.value))

    found = [
        e.id
        for e in state.elements.values()
        if e.type in types and all(passes(e, f) for f in query.filters)
    ]
    return sorted(found, key=id_sort_key)


EDGES = [0, 1, -1, 0.5, 1.0, -0.0, BIG, BIG + 1, float(BIG), math.nan, math.inf, -math.inf]
values = st.one_of(
    st.sampled_from([None, None, True, False, "a", *EDGES]),  # None: absent
    st.floats(-2, 2),
)
bounds = st.one_of(st.sampled_from(EDGES), st.floats(allow_nan=True, allow_infinity=True))
filters = st.builds(
    PropertyFilter,
    property=st.sampled_from(PROPS),
    op=st.sampled_from(["lt", "le", "gt", "ge", "lt", "ge", "eq", "exists"]),
    value=bounds,
)
steps = st.lists(
    st.one_of(
        st.tuples(
            st.just("put"),
            st.integers(0, 5),
            st.sampled_from(TYPES),
            st.lists(st.tuples(st.sampled_from(PROPS), values), max_size=2),
        ),
        st.tuples(st.just("remove"), st.integers(0, 5)),
        st.tuples(st.just("undo")),
        st.tuples(st.just("define")),
        st.tuples(
            st.just("query"),
            st.sampled_from(TYPES),
            st.booleans(),
            st.lists(filters, min_size=1, max_size=3),
        ),
    ),
    min_size=5,
    max_size=60,
)


BATTERY = [
    Query(type="Part", filters=[PropertyFilter(property="mass", op=op, value=bound)])
    for op in ("lt", "le", "gt", "ge")
    for bound in (math.nan, 0.5, 1, BIG)
]
"""Asked from the first step on, so hypothesis need not find the edge bounds by itself."""


@settings(max_examples=300, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(steps)
def test_range_filters_match_the_plain_filter(script: list[tuple[Any, ...]]) -> None:
    state = SceneState()
    known = 0  # run-time classes defined so far
    undo: list[Undo] = []
    asked = list(BATTERY)  # asked again after every step: their indexes exist by then
    for step in script:
        match step:
            case ("put", n, element_type, props):
                present = {k: v for k, v in props if v is not None}
                element = Element(id=f"E-{n}", type=element_type, properties=present)
                undo.append(state.put_element(element))
            case ("remove", n):
                undo.append(state.remove_element(f"E-{n}"))
            case ("undo",) if undo:
                state.undo(undo.pop())
            case ("define",) if known < len(RUNTIME):
                state.apply(ClassDefined(cls=RUNTIME[known]))  # kept: not on the undo stack
                known += 1
            case ("query", element_type, exact, fs):
                ontology = ONTOLOGIES[known]
                if element_type not in ontology.classes:
                    element_type = "Part"
                asked.append(Query(type=element_type, exact_type=exact, filters=fs))
        for query in asked:
            got = [e.id for e in resolve(state, ONTOLOGIES[known], query)]
            assert got == reference(ONTOLOGIES[known], state, query)
    fresh = SceneState.from_snapshot(state.to_snapshot())
    for element_type in TYPES:
        for prop in PROPS:
            kept = state.numeric.index(element_type, prop)
            assert all(v == v for v in kept.values) and kept.values == sorted(kept.values)
            rebuilt = fresh.numeric.index(element_type, prop)
            assert sorted(zip(kept.values, kept.ids, strict=True)) == sorted(
                zip(rebuilt.values, rebuilt.ids, strict=True)
            )


def test_nan_bound_and_untyped_query_use_the_index() -> None:
    state = SceneState()
    masses: list[Value] = [0.1, math.nan, 2, True, "3", 0.2]
    for n, mass in enumerate(masses):
        state.put_element(Element(id=f"Gear-{n}", type="Gear", properties={"mass": mass}))
    state.put_element(Element(id="Box-1", type="Box", properties={"mass": 0.05}))

    def ask(*fs: PropertyFilter) -> list[str]:
        return [e.id for e in resolve(state, BASE, Query(filters=list(fs)))]

    assert ask(PropertyFilter(property="mass", op="lt", value=math.nan)) == []
    assert ask(PropertyFilter(property="mass", op="le", value=0.2)) == [
        "Box-1",
        "Gear-0",
        "Gear-5",
    ]
    both = [
        PropertyFilter(property="mass", op="gt", value=0.0),
        PropertyFilter(property="mass", op="lt", value=1),
    ]
    assert ask(*both) == ["Box-1", "Gear-0", "Gear-5"]
    assert len(state.numeric) == 2  # (Gear, mass) and (Box, mass), built on first use


@pytest.mark.anyio
async def test_store_keeps_indexes_through_runtime_classes_and_rollback() -> None:
    store = await WmStore.open(BASE)
    light = Query(type="Part", filters=[PropertyFilter(property="mass", op="lt", value=0.5)])

    def check() -> list[str]:
        got = [e.id for e in resolve(store.state, store.ontology, light)]
        assert got == reference(store.ontology, store.state, light)
        return got

    async with anyio.create_task_group() as tg:
        await tg.start(store.run)
        await store.transact(Transact(ops=[AddElement(type="Gear", properties={"mass": 0.1})]))
        assert check() == ["Gear-1"]  # the (Gear, mass) index now exists
        await store.transact(Transact(ops=[AddElement(type="Gear", properties={"mass": 0.9})]))
        assert check() == ["Gear-1"]
        await store.transact(
            Transact(
                ops=[
                    DefineClass(cls=RUNTIME[0]),
                    AddElement(type="Widget", properties={"mass": 0.2}),
                ]
            )
        )
        assert check() == ["Gear-1", "Widget-1"]
        await store.transact(Transact(ops=[UpdateElement(id="Gear-2", properties={"mass": 0.3})]))
        assert check() == ["Gear-1", "Gear-2", "Widget-1"]
        with pytest.raises(ValidationError):  # applied, then rolled back by undo
            await store.transact(
                Transact(
                    ops=[
                        UpdateElement(id="Gear-1", properties={"mass": 5.0}),
                        RemoveElement(id="Widget-1"),
                        UpdateElement(id="Gear-99", properties={"mass": 0.1}),
                    ]
                )
            )
        assert check() == ["Gear-1", "Gear-2", "Widget-1"]
        await store.transact(Transact(ops=[RemoveElement(id="Gear-1")]))
        assert check() == ["Gear-2", "Widget-1"]
        past = store.snapshot(1)
        assert [e.id for e in past.elements] == ["Gear-1"]
        tg.cancel_scope.cancel()
    await store.aclose()
