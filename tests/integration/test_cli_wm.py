"""The ``skimesh`` command as a user runs it: a store process, then ``wm`` client commands."""

from __future__ import annotations

import json
import queue
import subprocess
import sys
import time
from collections.abc import Iterator
from pathlib import Path

import pytest

from .procs import ROOT, Child, start_store

pytestmark = [pytest.mark.zenoh, pytest.mark.slow]

SCENE = ROOT / "configs" / "scenes" / "sample.ttl"


def skimesh(*args: str) -> subprocess.CompletedProcess[str]:
    return subprocess.run(
        [sys.executable, "-m", "skimesh", *args],
        capture_output=True,
        text=True,
        timeout=60,
        cwd=ROOT,
    )


def test_wm_client_commands(router_endpoint: str, mesh_name: str, tmp_path: Path) -> None:
    store = start_store(router_endpoint, mesh_name, tmp_path / "wm")
    common = ["--connect", router_endpoint, "--mesh", mesh_name]
    try:
        imported = skimesh("wm", *common, "import", str(SCENE))
        assert imported.returncode == 0, imported.stderr
        assert "imported" in imported.stdout

        tree = skimesh("wm", *common, "tree")
        assert tree.returncode == 0, tree.stderr
        assert "contain → spur gear 1 (Gear-1) [Gear]" in tree.stdout

        listed = skimesh("wm", *common, "ls", "Part", "--json")
        parts = json.loads(listed.stdout)
        assert sorted(p["id"] for p in parts) == ["Gear-1", "Gear-2", "Shaft-1", "Shaft-2"]

        missing = skimesh("wm", *common, "query", "Gear", "--label", "nothing-like-this")
        assert missing.returncode == 1

        typo = skimesh("wm", *common, "ls", "Gaer")
        assert typo.returncode != 0
        assert "Gear" in typo.stderr, "the error names the closest class"

        exported = skimesh("wm", *common, "export", str(tmp_path / "scene.ttl"))
        assert exported.returncode == 0, exported.stderr
        assert "skm:Gear" in (tmp_path / "scene.ttl").read_text()

        info = json.loads(skimesh("wm", *common, "info").stdout)
        assert info["elements"] == len(parts) + 10
        assert info["durability"] == "group"
    finally:
        assert store.stop() == 0, store.log()


OVEN = """\
@prefix skm:  <https://skimesh.dev/ontology#> .
@prefix skms: <https://skimesh.dev/scene#> .
@prefix owl:  <http://www.w3.org/2002/07/owl#> .
@prefix rdfs: <http://www.w3.org/2000/01/rdf-schema#> .

skms:oven a owl:NamedIndividual , skm:Microwave ; rdfs:label "oven" .
"""


@pytest.fixture
def sample_store(router_endpoint: str, mesh_name: str, tmp_path: Path) -> Iterator[list[str]]:
    """A store process holding the sample scene (imported with --json at revision 1); yields
    the mesh flags of a client command."""
    store = start_store(router_endpoint, mesh_name, tmp_path / "wm")
    common = ["--connect", router_endpoint, "--mesh", mesh_name]
    try:
        imported = skimesh("wm", *common, "import", "--json", str(SCENE))
        assert imported.returncode == 0, imported.stderr
        summary = json.loads(imported.stdout)
        assert summary["revision"] == 1 and summary["elements"] == 14
        assert summary["ids"]["Gear-1"] == "Gear-1", "names of the <Class>-<n> form are kept"
        yield common
    finally:
        assert store.stop() == 0, store.log()


def test_get_tree_sparql_and_export(sample_store: list[str], tmp_path: Path) -> None:
    common = sample_store

    got = skimesh("wm", *common, "get", "Gear-1", "KitBox-1")
    assert got.returncode == 0, got.stderr
    elements = json.loads(got.stdout)
    assert [(e["id"], e["type"]) for e in elements] == [
        ("Gear-1", "Gear"),
        ("KitBox-1", "KitBox"),
    ]
    assert elements[0]["properties"]["mass"] == 0.12 and elements[0]["rev"] == 1
    missing = skimesh("wm", *common, "get", "Gear-1", "Gear-99")
    assert missing.returncode == 2 and missing.stdout == ""
    assert "Gear-99" in missing.stderr

    tree = json.loads(skimesh("wm", *common, "tree", "--json").stdout)
    assert [(n["id"], n["relation"]) for n in tree] == [
        ("MobileManipulator-1", None),
        ("Station-1", None),
    ]
    shelf = tree[1]["children"][0]
    assert (shelf["id"], shelf["type"], shelf["relation"]) == ("Shelf-1", "Shelf", "contain")
    box = shelf["children"][0]
    assert box["label"] == "gears and shafts"
    assert [c["id"] for c in box["children"]] == ["Gear-1", "Gear-2", "Shaft-1", "Shaft-2"]
    assert all(c["children"] == [] for c in box["children"])
    sub = json.loads(skimesh("wm", *common, "tree", "PartBox-1", "--json").stdout)
    assert sub == [{**box, "relation": None}], "a ROOT gives that branch alone"

    question = "SELECT ?e ?m WHERE { ?e a skm:Gear ; skm:rev ?r ; skm:mass ?m } ORDER BY ?e"
    table = skimesh("wm", *common, "sparql", question)
    assert table.returncode == 0, table.stderr
    assert table.stdout.splitlines() == ["e\tm", "Gear-1\t0.12", "Gear-2\t0.12"]
    rows = json.loads(skimesh("wm", *common, "sparql", "--json", question).stdout)
    assert rows == {
        "revision": 1,
        "variables": ["e", "m"],
        "rows": [{"e": "Gear-1", "m": "0.12"}, {"e": "Gear-2", "m": "0.12"}],
    }
    update = skimesh("wm", *common, "sparql", "DELETE WHERE { ?s ?p ?o }")
    assert update.returncode == 2 and "read-only" in update.stderr

    exported = json.loads(skimesh("wm", *common, "export", "--json").stdout)
    assert (exported["revision"], exported["elements"]) == (1, 14)
    assert exported["file"] is None and "skms:Gear-1" in exported["turtle"]
    assert exported["bytes"] == len(exported["turtle"].encode())
    target = tmp_path / "scene.ttl"
    to_file = skimesh("wm", *common, "export", "--json", str(target))
    written = json.loads(to_file.stdout)
    assert written["file"] == str(target) and "turtle" not in written
    assert written["bytes"] == target.stat().st_size
    assert written["relations"] == exported["relations"] == 14  # as in configs/scenes/sample.ttl


def test_check_reports_unmet_minimum_cardinalities(sample_store: list[str], tmp_path: Path) -> None:
    common = sample_store
    clean = skimesh("wm", *common, "check")
    assert clean.returncode == 0, clean.stderr + clean.stdout
    assert "14 element(s) at revision 1: every one met" in clean.stdout

    (tmp_path / "oven.ttl").write_text(OVEN)
    oven = json.loads(skimesh("wm", *common, "import", "--json", str(tmp_path / "oven.ttl")).stdout)
    assert oven == {"revision": 2, "elements": 1, "ids": {"oven": "Microwave-1"}}
    short = skimesh("wm", *common, "check")
    assert short.returncode == 1, short.stderr
    assert short.stdout.splitlines()[0] == (
        "Microwave-1: a Microwave should have exactly 1 'hasA' to a MicrowaveDoor "
        "(declared on Microwave); it has 0"
    )
    report = skimesh("wm", *common, "check", "--json")
    assert report.returncode == 1
    found = json.loads(report.stdout)
    assert (found["revision"], found["checked"]) == (2, 15)
    assert [
        (v["element"], v["relation"], v["on_class"], v["required"], v["present"])
        for v in found["violations"]
    ] == [("Microwave-1", "hasA", "MicrowaveDoor", 1, 0)]
    narrowed = skimesh("wm", *common, "check", "--json", "Gear-1", "KitBox-1")
    assert narrowed.returncode == 0
    assert json.loads(narrowed.stdout) == {"revision": 2, "checked": 2, "violations": []}


def test_no_store_fails_fast_with_advice(router_endpoint: str, mesh_name: str) -> None:
    result = skimesh(
        "wm", "--connect", router_endpoint, "--mesh", mesh_name, "--timeout", "1", "ls"
    )
    assert result.returncode != 0
    assert "skimesh wm" in result.stderr


BEARINGS = """\
@prefix skm:  <https://skimesh.dev/ontology#> .
@prefix owl:  <http://www.w3.org/2002/07/owl#> .
@prefix rdfs: <http://www.w3.org/2000/01/rdf-schema#> .

skm:Bearing a owl:Class ; rdfs:subClassOf skm:Part ; rdfs:label "bearing"@en .
"""

PULLEY_SCENE = """\
@prefix skm:  <https://skimesh.dev/ontology#> .
@prefix skms: <https://skimesh.dev/scene#> .

skms:p1 a skm:Pulley ; skm:inspected true ; skm:heldBy skms:b1 .
skms:b1 a skm:Bearing .
"""


def test_the_store_teaches_the_whole_mesh(
    router_endpoint: str, mesh_name: str, tmp_path: Path
) -> None:
    """A store started with --ontology; clients with no ontology of their own use its terms,
    teach more, and an export re-imports whole into a new store."""
    ext = tmp_path / "bearings.ttl"
    ext.write_text(BEARINGS)
    common = ["--connect", router_endpoint, "--mesh", mesh_name]
    store = Child(
        ["-m", "skimesh", "wm", *common, "--data", str(tmp_path / "wm"), "--ontology", str(ext)],
        name="store",
    )
    try:
        store.wait_stderr("world model ready")
        assert skimesh("wm", *common, "ls", "Bearing").returncode == 1, "known class, no element"
        refused = skimesh("wm", *common, "--ontology", str(ext), "ls", "Bearing")
        assert refused.returncode != 0 and "wm teach" in refused.stderr

        steps = [
            ("define-class", "Pulley", "--parent", "Part", "--comment", "a wheel for a belt"),
            ("define-property", "inspected", "--kind", "bool", "--domain", "Part"),
            ("define-relation", "heldBy", "--domain", "Pulley", "--range", "Bearing"),
            ("define-template", "big-pulley", "--type", "Pulley", "--set", "mass=0.4"),
        ]
        for step in steps:
            done = skimesh("wm", *common, *step)
            assert done.returncode == 0 and "taught at revision" in done.stdout, done.stderr
        again = skimesh("wm", *common, "teach", str(ext))
        assert again.returncode == 0 and "known already" in again.stdout, again.stderr
        bad = tmp_path / "bad.ttl"
        bad.write_text("skm:Broken a")
        refused = skimesh("wm", *common, "teach", str(bad))
        assert refused.returncode != 0 and "bad.ttl" in refused.stderr

        scene = tmp_path / "pulleys.ttl"
        scene.write_text(PULLEY_SCENE)
        imported = skimesh("wm", *common, "import", str(scene))
        assert imported.returncode == 0, imported.stderr
        taught = skimesh("wm", *common, "ontology", "--taught")
        assert "# ---- taught: bearings.ttl" in taught.stdout, taught.stdout
        assert "skm:heldBy" in taught.stdout and "class Pulley" in taught.stdout
        assert "template big-pulley" in taught.stdout
        whole = skimesh("wm", *common, "ontology")
        assert "skm:Bearing" in whole.stdout and "skm:MobileManipulator" in whole.stdout
        export = tmp_path / "site.ttl"
        assert skimesh("wm", *common, "export", str(export)).returncode == 0
    finally:
        assert store.stop() == 0, store.log()

    # A new store, core ontology only: the export brings its terms along.
    fresh = start_store(router_endpoint, f"{mesh_name}-b", tmp_path / "wm2")
    other = ["--connect", router_endpoint, "--mesh", f"{mesh_name}-b"]
    try:
        imported = skimesh("wm", *other, "import", str(export))
        assert imported.returncode == 0, imported.stderr
        listed = json.loads(skimesh("wm", *other, "query", "Pulley", "--json").stdout)
        assert [p["properties"]["inspected"] for p in listed] == [True]
        assert skimesh("wm", *other, "ls", "Bearing").returncode == 0
    finally:
        assert fresh.stop() == 0, fresh.log()


def test_an_import_over_one_transactions_limit_goes_in_batches(
    router_endpoint: str, mesh_name: str, tmp_path: Path
) -> None:
    """10,010 individuals: more than a transaction takes (10,000 ops)."""
    body = "".join(f'skms:p{i} a skm:Gear ; rdfs:label "part {i}" .\n' for i in range(10_010))
    big = tmp_path / "big.ttl"
    big.write_text(
        "@prefix skm: <https://skimesh.dev/ontology#> .\n"
        "@prefix skms: <https://skimesh.dev/scene#> .\n"
        "@prefix rdfs: <http://www.w3.org/2000/01/rdf-schema#> .\n" + body
    )
    store = start_store(router_endpoint, mesh_name, tmp_path / "wm")
    common = ["--connect", router_endpoint, "--mesh", mesh_name]
    try:
        done = skimesh("wm", *common, "import", str(big), "--timeout", "30")
        assert done.returncode == 0, done.stderr
        assert "imported 10010 elements" in done.stdout
        assert "5000/10010 ops" in done.stderr and "10010/10010 ops" in done.stderr
        info = json.loads(skimesh("wm", *common, "info").stdout)
        assert info["elements"] == 10_010
    finally:
        assert store.stop() == 0, store.log()


def test_writes_watch_and_history_from_the_command_line(
    router_endpoint: str, mesh_name: str, tmp_path: Path
) -> None:
    store = start_store(router_endpoint, mesh_name, tmp_path / "wm")
    common = ["--connect", router_endpoint, "--mesh", mesh_name]
    watch = Child(["-m", "skimesh", "wm", *common, "watch", "--json"], name="watch")
    words = Child(["-m", "skimesh", "wm", *common, "watch"], name="watch-words")
    try:
        watch.wait_stderr("following")
        words.wait_stderr("following")
        box = skimesh("wm", *common, "add", "Box", "--label", "bin-a")
        assert box.returncode == 0, box.stderr
        box_id = box.stdout.strip()
        gear = skimesh(
            "wm", *common, "add", "Gear", "--label", "gear-z", "--set", "mass=0.12", "--in", box_id
        )
        assert gear.returncode == 0, gear.stderr
        gear_id = gear.stdout.strip()
        seen = watch.expect(lambda c: any("element" in d and d["element"]["id"] == gear_id
                                          for d in c["deltas"]))  # fmt: skip
        assert seen["author"] == "cli"

        steps = [
            ("update", gear_id, "--set", "mass=0.2", "--label", "gear-y"),
            ("relate", "bin-a", "near", "gear-y"),  # by label: a label only it has
            ("unrelate", box_id, "near", gear_id),
        ]
        for step in steps:
            done = skimesh("wm", *common, *step)
            assert done.returncode == 0 and "revision" in done.stdout, done.stderr
        got = json.loads(skimesh("wm", *common, "get", gear_id).stdout)[0]
        assert got["label"] == "gear-y" and got["properties"]["mass"] == 0.2
        # in words, against the state before each change
        added = _line_with(words, f"gear-z ({gear_id})")
        assert added.startswith("rev 2 by cli: +gear-z") and "[Gear]" in added, added
        updated = _line_with(words, "mass")
        assert updated == (
            f'rev 3 by cli: gear-y ({gear_id}) label "gear-z" -> "gear-y", mass 0.12 -> 0.2'
        )

        wrong = skimesh("wm", *common, "update", gear_id, "--set", "mass=-1")
        assert wrong.returncode != 0 and "mass" in wrong.stderr, "checked as any write"
        twice = skimesh("wm", *common, "add", "Box", "--label", "bin-a")
        assert twice.returncode != 0 and "bin-a" in twice.stderr, "labels are unique"

        history = skimesh("wm", *common, "history", "--since", "1")
        lines = history.stdout.strip().splitlines()
        assert history.returncode == 0 and len(lines) == 4, history.stdout
        assert lines[0].startswith("rev 2 by cli: +gear-z") and "+near" in lines[2]
        assert lines[1] == updated, "history learns the gear from revision 2"
        removed = skimesh("wm", *common, "remove", "bin-a", "--branch")
        assert removed.returncode == 0, removed.stderr
        assert skimesh("wm", *common, "get", gear_id).returncode != 0, "removed with its box"
    finally:
        words.stop()
        watch.stop()
        assert store.stop() == 0, store.log()


def _line_with(child: Child, needle: str, timeout: float = 30.0) -> str:
    """The next line ``child`` printed that contains ``needle`` (the lines before it read)."""
    deadline = time.monotonic() + timeout
    while True:
        try:
            line = child.stdout.get(timeout=max(0.1, deadline - time.monotonic()))
        except queue.Empty:
            raise AssertionError(f"{child.name}: no {needle!r} in {timeout} s") from None
        if line is None:
            raise AssertionError(f"{child.name} ended early:\n{child.log()}")
        if needle in line:
            return line.rstrip("\n")
