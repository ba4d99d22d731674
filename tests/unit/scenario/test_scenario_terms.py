"""A scenario's own ontology terms (its ``ontology`` files): resolved against the scenario
file, taught first in the transaction that loads its scene, and refused clearly when broken."""

from __future__ import annotations

from pathlib import Path

import pytest

from scenario import ScenarioError, load_scenario
from scenario.wm import scenario_terms, scene_ops
from skimesh.paths import configs_dir
from wm_store.ontology import Ontology
from wm_store.protocol import AddElement, DefineTerms
from wm_store.scene import SceneState, apply_transaction

KITTING = configs_dir() / "scenarios" / "kitting" / "scenario.toml"
TERMS = """\
@prefix skm: <https://skimesh.dev/ontology#> .
@prefix owl: <http://www.w3.org/2002/07/owl#> .
@prefix rdfs: <http://www.w3.org/2000/01/rdf-schema#> .
skm:Bearing a owl:Class ; rdfs:subClassOf skm:Part .
"""


def scenario_with_terms(tmp_path: Path, terms: str | None) -> Path:
    text = KITTING.read_text().replace("../../agents/", f"{KITTING.parents[2]}/agents/")
    text = text.replace('type = "Gear"', 'type = "Bearing"', 1)  # the first gear, Gear-1
    text = text.replace('"Gear-1"', '"Bearing-1"').replace("Gear-1)", "Bearing-1)")
    text = text.replace("\n[[robots]]", '\nontology = ["parts.ttl"]\n\n[[robots]]', 1)
    if terms is not None:
        (tmp_path / "parts.ttl").write_text(terms)
    path = tmp_path / "scenario.toml"
    path.write_text(text)
    return path


def test_the_terms_come_first_and_make_the_scene_valid(tmp_path: Path) -> None:
    scenario = load_scenario(scenario_with_terms(tmp_path, TERMS))
    assert scenario.ontology == [str(tmp_path / "parts.ttl")]
    ops = scene_ops(scenario, SceneState(), Ontology.default())
    assert isinstance(ops[0], DefineTerms) and ops[0].terms.source == "parts.ttl"
    assert any(isinstance(op, AddElement) and op.type == "Bearing" for op in ops)
    state = SceneState()
    result = apply_transaction(state, Ontology.default(), ops, revision=1, now=0.0)
    assert result.ontology.is_a("Bearing", "Part")
    assert state.ids_with_label("Bearing-1") == {"Bearing-1"}


def test_a_missing_or_broken_terms_file_is_named(tmp_path: Path) -> None:
    scenario = load_scenario(scenario_with_terms(tmp_path, None))
    with pytest.raises(ScenarioError, match=r"parts\.ttl"):
        scenario_terms(scenario)
    broken = load_scenario(scenario_with_terms(tmp_path, "skm:Bearing a"))
    with pytest.raises(ScenarioError, match=r"parts\.ttl"):
        scene_ops(broken, SceneState(), Ontology.default())
