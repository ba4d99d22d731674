"""World-model changes in words: an element that is new, what an update changed (old -> new),
a relabelling, a removal by name, a put that changed nothing, and the cap on long changes."""

from __future__ import annotations

import pytest

from wm_store import ChangeWords, describe_change
from wm_store.protocol import (
    Change,
    Delta,
    Element,
    ElementPut,
    ElementRemoved,
    Observation,
    Orientation,
    Pose,
    Position,
    Relation,
    RelationAdded,
    RelationRemoved,
    SizeCuboid,
    Value,
)

from .stores import memory_client


def pose(x: float, y: float, z: float, frame: str = "") -> Pose:
    return Pose(position=Position(x, y, z), frame=frame)


GEAR = Element(id="Gear-1", type="Gear", properties={"pose": pose(1.0782, -1.25, 0.72)})
KIT = Element(id="KitBox-1", type="KitBox", label="kit")


def change(revision: int, *deltas: Delta, ids: dict[str, str] | None = None) -> Change:
    return Change(revision=revision, author="r1", stamp=0.0, deltas=list(deltas), ids=ids or {})


def put(element: Element, **changes: object) -> ElementPut:
    properties: dict[str, Value] = dict(element.properties)
    properties.update(changes.pop("properties", {}))  # type: ignore[call-overload]
    return ElementPut(
        element=Element(
            id=element.id,
            type=element.type,
            label=str(changes.get("label", element.label)),
            properties=properties,
            observations=changes.get("observations", element.observations),  # type: ignore[arg-type]
            rev=element.rev + 1,
        )
    )


def test_a_new_element_is_named_with_its_class_and_where_it_is() -> None:
    words = ChangeWords([GEAR, KIT], revision=4)
    gear9 = Element(id="Gear-9", type="Gear", label="spare", properties={"pose": pose(0.4, 0.1, 0)})
    line = words(
        change(5, ElementPut(gear9), RelationAdded(Relation("KitBox-1", "contain", "Gear-9")))
    )
    assert line == (
        "rev 5 by r1: +spare (Gear-9) [Gear] at (0.400, 0.100, 0.000); "
        "+contain(kit (KitBox-1), spare (Gear-9))"
    )


def test_an_update_says_which_property_changed_from_what_to_what() -> None:
    words = ChangeWords([GEAR, KIT], revision=4)
    moved = put(GEAR, properties={"pose": pose(0.445, -0.9981, 0.37)})
    assert words(change(5, moved)) == (
        "rev 5 by r1: Gear-1 pose (1.078, -1.250, 0.720) -> (0.445, -0.998, 0.370)"
    )
    # learnt: the next update is against this one
    again = put(moved.element, properties={"pose": pose(0.5, -0.9981, 0.37, frame="KitBox-1")})
    assert words(change(6, again)) == (
        "rev 6 by r1: Gear-1 pose (0.445, -0.998, 0.370) -> "
        "(0.500, -0.998, 0.370) in kit (KitBox-1)"
    )


def test_several_properties_the_first_few_with_values_and_seen_for_observations() -> None:
    words = ChangeWords([GEAR], revision=1)
    seen = Observation(value=pose(0.3, 0.2, 0.1), source="r1-camera", stamp=5.0)
    updated = put(
        GEAR,
        properties={
            "pose": None,
            "mass": 0.12,
            "size": SizeCuboid(0.1, 0.2, 0.3),
            "note": "x" * 60,
            "seenAt": 5.0,
        },
        observations={"pose": [seen]},
    )
    line = words(change(2, updated))
    assert line == (
        "rev 2 by r1: Gear-1 pose (1.078, -1.250, 0.720) -> unset, mass unset -> 0.12, "
        "size unset -> 0.1x0.2x0.3 m, note, seen by r1-camera"
    )
    turned = put(updated.element, properties={"mass": 0.2, "seenAt": 6.0})
    assert words(change(3, turned)) == "rev 3 by r1: Gear-1 mass 0.12 -> 0.2, seen"


def test_an_orientation_change_shows_and_many_changes_are_counted() -> None:
    words = ChangeWords([GEAR], revision=1)
    turned = Pose(position=Position(1.0782, -1.25, 0.72), orientation=Orientation(z=1.0, w=0.0))
    line = words(change(2, put(GEAR, properties={"pose": turned})))
    assert line.endswith("-> (1.078, -1.250, 0.720) yaw 180.0°")
    tilted = Pose(position=Position(1.0782, -1.25, 0.72), orientation=Orientation(x=1.0, w=0.0))
    line = words(change(3, put(GEAR, properties={"pose": tilted})))
    assert line.endswith("yaw 180.0° -> (1.078, -1.250, 0.720) q(1.000, 0.000, 0.000, 0.000)")
    many = put(GEAR, properties={f"p{i}": i for i in range(8)})
    line = words(change(4, many))
    assert line.startswith("rev 4 by r1: Gear-1 pose ")
    assert line.endswith(", p0 unset -> 0, p1 unset -> 1, p2, p3, 4 more")


def test_a_label_change_names_the_element_by_its_new_name() -> None:
    words = ChangeWords([KIT], revision=1)
    assert words(change(2, put(KIT, label="kit-2"))) == (
        'rev 2 by r1: kit-2 (KitBox-1) label "kit" -> "kit-2"'
    )


def test_a_removed_element_is_named_as_it_was_and_forgotten() -> None:
    words = ChangeWords([GEAR, KIT], revision=1)
    line = words(
        change(
            2,
            RelationRemoved(Relation("KitBox-1", "contain", "Gear-1")),
            ElementRemoved("KitBox-1"),
        )
    )
    assert line == "rev 2 by r1: -contain(kit (KitBox-1), Gear-1); removed kit (KitBox-1)"
    back = Element(id="KitBox-1", type="KitBox", label="kit")
    assert words(change(3, ElementPut(back))) == "rev 3 by r1: +kit (KitBox-1) [KitBox]"


def test_a_put_that_changed_nothing_is_said_briefly_or_left_out() -> None:
    words = ChangeWords([GEAR, KIT], revision=1)
    assert words(change(2, put(GEAR))) == "rev 2 by r1: Gear-1 unchanged"
    both = words(change(3, put(GEAR), put(KIT, properties={"mass": 1.5})))
    assert both == "rev 3 by r1: kit (KitBox-1) mass unset -> 1.5"


def test_an_element_put_twice_in_one_change_is_worded_once_against_before() -> None:
    words = ChangeWords([KIT], revision=1)
    first = put(KIT, properties={"mass": 1.0})
    second = put(first.element, properties={"mass": 2.0})
    assert words(change(2, first, second)) == "rev 2 by r1: kit (KitBox-1) mass unset -> 2"


def test_many_items_are_counted_and_still_learnt() -> None:
    words = ChangeWords([GEAR], revision=1)
    gears = [ElementPut(Element(id=f"Gear-{i}", type="Gear")) for i in range(2, 10)]
    moved = put(GEAR, properties={"mass": 3.0})
    assert words(change(2, *gears, moved)) == "rev 2 by r1: 9 deltas (8 new, 1 updated)"
    assert words(change(3, put(gears[0].element, label="g"))) == (
        'rev 3 by r1: g (Gear-2) label "" -> "g"'
    )


def test_without_prior_knowledge_a_put_is_a_put_unless_added_or_from_the_start() -> None:
    gear = ElementPut(Element(id="Gear-1", type="Gear", label="gear"))
    box = ElementPut(Element(id="Box-1", type="Box"))
    assert describe_change(change(42, gear, box, ElementRemoved("Bolt-9"))) == (
        "rev 42 by r1: put gear (Gear-1) [Gear]; put Box-1 [Box]; removed Bolt-9"
    )
    added = change(42, gear, box, ids={"$new": "Box-1"})
    assert describe_change(added) == "rev 42 by r1: put gear (Gear-1) [Gear]; +Box-1 [Box]"
    named = change(7, RelationAdded(Relation("KitBox-1", "contain", "Gear-1")))
    kit = {"KitBox-1": "kit"}
    assert describe_change(named, lambda i: kit.get(i, i)) == "rev 7 by r1: +contain(kit, Gear-1)"
    words = ChangeWords()  # learning from the start: revision 1 follows the empty store
    assert words(change(1, gear)) == "rev 1 by r1: +gear (Gear-1) [Gear]"
    assert words(change(2, put(gear.element, label="g2"))) == (
        'rev 2 by r1: g2 (Gear-1) label "gear" -> "g2"'
    )
    assert words(change(5, box)) == "rev 5 by r1: put Box-1 [Box]", "changes 3, 4 were missed"


@pytest.mark.anyio
async def test_seeded_from_a_replica_it_words_its_watch_stream() -> None:
    async with memory_client() as wm:
        gear = await wm.add_element("Gear", label="gear-z", properties={"mass": 0.12})
        lines: list[str] = []
        async with wm.watch() as changes:
            words = ChangeWords(wm.replica.state.elements.values(), revision=wm.revision)
            await wm.update_element(gear, {"mass": 0.2}, label="gear-y")
            added = await wm.add_element("Box", label="bin")
            await wm.remove_element(added)
            async for one in changes:
                lines.append(words(one))
                if len(lines) == 3:
                    break
    assert lines[0].endswith(f'gear-y ({gear}) label "gear-z" -> "gear-y", mass 0.12 -> 0.2')
    assert lines[1].endswith(f"+bin ({added}) [Box]")
    assert lines[2].endswith(f"removed bin ({added})")
