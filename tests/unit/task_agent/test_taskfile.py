"""Task files: strict loading with located errors, ids by position, data-flow references, and
the walk helpers (document order, what may run in parallel, what precedes what)."""

from __future__ import annotations

from pathlib import Path

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from task_agent import VerificationError
from task_agent.protocol import Call, Parallel, Sequence, TaskBlock, TaskFile
from task_agent.taskfile import (
    Ref,
    assign_ids,
    blocks,
    load_task_file,
    parse_ref,
    precedes,
    read_task_file,
    walk,
    where,
)
from wm_store.protocol import Position

ASSETS = Path(__file__).resolve().parents[2] / "assets" / "tasks"

NESTED = """\
name = "nested"

[root]
block = "sequence"

[[root.children]]
block = "call"
id = "first"
agent = "r1"
skill = "navigate"
params = { goal = "label:Station-1" }

[[root.children]]
block = "parallel"

[[root.children.children]]
block = "call"
skill = "locate"
params = { object = "@first.goal" }

[[root.children.children]]
block = "sequence"

[[root.children.children.children]]
block = "call"
skill = "pick"

[[root.children.children.children]]
block = "call"
skill = "place"

[[root.children]]
block = "call"
skill = "navigate"
"""


def call(skill: str = "s", id: str = "") -> Call:
    return Call(skill=skill, id=id)


# --------------------------------------------------------------------------- loading


def test_load_assigns_positional_ids_and_keeps_explicit_ones() -> None:
    task = load_task_file(NESTED)
    assert task.name == "nested"
    assert isinstance(task.root, Sequence) and task.root.id == "root"
    first, par, last = task.root.children
    assert isinstance(first, Call) and first.id == "first"
    assert first.params == {"goal": "label:Station-1"}
    assert isinstance(par, Parallel) and par.id == "root.1"
    inner = par.children[1]
    assert isinstance(inner, Sequence) and [c.id for c in inner.children] == [
        "root.1.1.0",
        "root.1.1.1",
    ]
    assert isinstance(last, Call) and last.id == "root.2" and last.agent == ""


def test_assign_ids_is_idempotent_and_fills_code_built_tasks() -> None:
    task = TaskFile(root=Sequence(children=[call("a"), Parallel(children=[call("b")], id="p")]))
    named = assign_ids(task)
    assert assign_ids(named) == named
    assert [s.block.id for s in blocks(named)] == ["root", "root.0", "p", "root.1.0"]


def test_typed_values_load_as_structs() -> None:
    text = """
[root]
block = "call"
skill = "move"
params = { to = { type = "Position", x = 1, y = 2.5, z = 0 }, names = ["a", "b"] }
"""
    root = load_task_file(text).root
    assert isinstance(root, Call) and root.id == "root"
    assert root.params["to"] == Position(1.0, 2.5, 0.0)
    assert root.params["names"] == ["a", "b"]


@pytest.mark.parametrize(
    ("text", "expected"),
    [
        ("[root\nblock = 1", r"f\.toml: invalid TOML: .*line 1"),
        (
            NESTED.replace('skill = "place"', "skill = 3"),
            r"f\.toml:30: Expected `str`, got `int` - at `\$\.root\.children\[1\]\.children\[1\]"
            r"\.children\[1\]\.skill` \(block root\.1\.1\.1\)",
        ),
        (
            NESTED.replace('block = "parallel"', 'block = "paralel"'),
            r"f\.toml:14: Invalid value 'paralel' .*; a block is 'call', 'sequence' or 'parallel' "
            r"\(block root\.1\)",
        ),
        (
            NESTED.replace('skill = "pick"', 'skill = "pick"\nagnet = "r1"'),
            r"f\.toml:27: unknown field `agnet` in a call block; did you mean 'agent'\? "
            r"\(block root\.1\.1\.0\)",
        ),
        (
            "nme = 'x'\n" + NESTED,
            r"f\.toml:1: unknown top-level field `nme`; did you mean 'name'\? A task file has",
        ),
        ('name = "no root"', r"f\.toml: Object missing required field `root`"),
        (
            NESTED.replace('goal = "label:Station-1"', "goal = 1979-05-27"),
            r"f\.toml:11: Expected .*got `date` - at `\$\.root\.children\[0\]\.params\[\.\.\.\]` "
            r"\(block root\.0\)",
        ),
    ],
    ids=["syntax", "type", "block", "unknown-key", "top-level", "missing-root", "date"],
)
def test_load_errors_name_the_line_the_path_and_the_block(text: str, expected: str) -> None:
    with pytest.raises(VerificationError, match=expected):
        load_task_file(text, source="f.toml")


def test_inline_children_load_and_errors_point_at_their_key() -> None:
    text = (
        '[root]\nblock = "sequence"\nchildren = [\n  { block = "call", skill = "a" },\n'
        '  { block = "call", skill = 2 },\n]\n'
    )
    with pytest.raises(VerificationError, match=r"^t:3: .*children\[1\]\.skill` \(block root\.1\)"):
        load_task_file(text, source="t")
    task = load_task_file(text.replace("skill = 2", 'skill = "b"'))
    assert [c.call.id for c in walk(task)] == ["root.0", "root.1"]


def test_read_task_file(tmp_path: Path) -> None:
    task = read_task_file(ASSETS / "kitting_good.toml")
    assert task.name == "kit four parts"
    with pytest.raises(VerificationError, match=r"cannot read task file .*missing\.toml"):
        read_task_file(tmp_path / "missing.toml")
    bad = tmp_path / "bad.toml"
    bad.write_text("[root]\n", encoding="utf-8")
    with pytest.raises(VerificationError, match=r"bad\.toml:1: Object missing required field"):
        read_task_file(bad)


def test_every_asset_and_example_loads() -> None:
    configs = Path(__file__).resolve().parents[3] / "configs" / "tasks"
    files = sorted(ASSETS.glob("*.toml")) + sorted(configs.glob("*.toml"))
    assert len(files) >= 9
    for path in files:
        assert walk(read_task_file(path)), path


# --------------------------------------------------------------------------- references


@pytest.mark.parametrize(
    ("value", "ref"),
    [
        ("@pick1.object", Ref("pick1", "object")),
        ("@root.1.0.goal", Ref("root.1.0", "goal")),
        ("@pick1", Ref("pick1", "")),
        ("Gear-1", None),
        ("label:Station-1", None),
        (3, None),
        (None, None),
    ],
)
def test_parse_ref(value: str | int | None, ref: Ref | None) -> None:
    assert parse_ref(value) == ref


def test_where_names_explicit_ids_only() -> None:
    assert where("root.1", call(id="root.1")) == "root.1"
    assert where("root.1", call(id="")) == "root.1"
    assert where("root.1", call(id="pick1")) == "root.1 (pick1)"


# --------------------------------------------------------------------------- walking


def test_walk_lists_calls_in_document_order_with_their_parallel_peers() -> None:
    sites = walk(load_task_file(NESTED))
    assert [s.path for s in sites] == ["root.0", "root.1.0", "root.1.1.0", "root.1.1.1", "root.2"]
    peers = {s.path: s.parallel for s in sites}
    assert peers == {
        "root.0": (),
        "root.1.0": ("root.1.1.0", "root.1.1.1"),
        "root.1.1.0": ("root.1.0",),
        "root.1.1.1": ("root.1.0",),
        "root.2": (),
    }
    by = {s.path: s for s in sites}
    assert precedes(by["root.0"], by["root.1.0"]) and precedes(by["root.1.1.0"], by["root.1.1.1"])
    assert precedes(by["root.1.1.1"], by["root.2"])
    assert not precedes(by["root.1.0"], by["root.1.1.1"])
    assert not precedes(by["root.2"], by["root.0"]) and not precedes(by["root.0"], by["root.0"])


def test_a_lone_call_is_the_root() -> None:
    (site,) = walk(load_task_file('[root]\nblock = "call"\nskill = "heat"'))
    assert (site.path, site.call.id, site.parallel, site.trail) == ("root", "root", (), ())


def _trees(depth: int) -> st.SearchStrategy[TaskBlock]:
    leaf = st.builds(Call, skill=st.sampled_from(["a", "b"]))
    if depth == 0:
        return leaf
    kids = st.lists(_trees(depth - 1), max_size=4)
    return st.one_of(
        leaf,
        st.builds(Sequence, children=kids),
        st.builds(Parallel, children=kids),
    )


def _reference(block: TaskBlock, path: str) -> tuple[list[str], set[tuple[str, str]], set[str]]:
    """Independent semantics: the calls under ``block``, the ordered pairs, the concurrent
    pairs (as "a|b")."""
    if isinstance(block, Call):
        return [path], set(), set()
    calls: list[list[str]] = []
    before: set[tuple[str, str]] = set()
    together: set[str] = set()
    for i, child in enumerate(block.children):
        c, b, t = _reference(child, f"{path}.{i}")
        calls.append(c)
        before |= b
        together |= t
    for i, first in enumerate(calls):
        for second in calls[i + 1 :]:
            for a in first:
                for z in second:
                    if isinstance(block, Sequence):
                        before.add((a, z))
                    else:
                        together |= {f"{a}|{z}", f"{z}|{a}"}
    return [c for group in calls for c in group], before, together


@settings(max_examples=150, deadline=None)
@given(_trees(3))
def test_walk_agrees_with_the_reference_semantics(root: TaskBlock) -> None:
    task = assign_ids(TaskFile(root=root))
    sites = walk(task)
    calls, before, together = _reference(task.root, "root")
    assert [s.path for s in sites] == calls
    ids = [s.block.id for s in blocks(task)]
    assert len(ids) == len(set(ids))
    for a in sites:
        assert set(a.parallel) == {z.path for z in sites if f"{a.path}|{z.path}" in together}
        for z in sites:
            assert precedes(a, z) == ((a.path, z.path) in before)
            if a is not z:  # exactly one of: a first, z first, at the same time
                relations = [precedes(a, z), precedes(z, a), z.path in a.parallel]
                assert relations.count(True) == 1
            if precedes(a, z):
                assert a.order < z.order
