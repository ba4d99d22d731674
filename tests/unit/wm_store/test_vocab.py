"""``wm_store/ontology/_vocab.py`` is generated from the core ontology and must stay in step
with it."""

from __future__ import annotations

import importlib.util
from pathlib import Path
from types import ModuleType

import pytest

from wm_store.ontology import Ontology, core_ontology_path
from wm_store.ontology import _vocab as vocab

ROOT = Path(__file__).resolve().parents[3]


@pytest.fixture(scope="module")
def gen_vocab() -> ModuleType:
    spec = importlib.util.spec_from_file_location("gen_vocab", ROOT / "scripts" / "gen_vocab.py")
    assert spec is not None
    assert spec.loader is not None
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def constants(holder: type) -> dict[str, str]:
    return {k: v for k, v in vars(holder).items() if not k.startswith("_")}


def test_vocab_is_up_to_date(gen_vocab: ModuleType) -> None:
    expected = gen_vocab.render(Ontology.load(core_ontology_path()))
    current = (ROOT / "wm_store" / "ontology" / "_vocab.py").read_text(encoding="utf-8")
    assert current == expected, (
        "wm_store/ontology/_vocab.py is stale: run `python scripts/gen_vocab.py`"
    )


@pytest.mark.parametrize(
    ("holder", "kind"),
    [
        (vocab.Cls, "classes"),
        (vocab.Rel, "relations"),
        (vocab.Prop, "data_properties"),
        (vocab.Tpl, "templates"),
    ],
)
def test_every_constant_names_an_ontology_term(
    gen_vocab: ModuleType, holder: type, kind: str
) -> None:
    names = set(getattr(Ontology.default(), kind))
    values = constants(holder)
    assert set(values.values()) == names
    assert all(attr == gen_vocab.identifier(value) for attr, value in values.items())


def test_constants_work_with_the_ontology() -> None:
    onto = Ontology.default()
    assert str(onto.namespace) == vocab.NAMESPACE
    assert onto.is_a(vocab.Cls.KitBox, vocab.Cls.Container)
    assert onto.check_relation(vocab.Cls.Gripper, vocab.Rel.contain, vocab.Cls.Gear).spatial
    onto.check_value(vocab.Prop.graspWidth, 0.1)
    assert onto.template(vocab.Tpl.DefaultKitBox).type == vocab.Cls.KitBox


def test_check_mode_detects_a_stale_file(gen_vocab: ModuleType, tmp_path: Path) -> None:
    out = tmp_path / "vocab.py"
    assert gen_vocab.main(["--output", str(out), "--check"]) == 1  # missing counts as stale
    assert gen_vocab.main(["--output", str(out)]) == 0
    assert gen_vocab.main(["--output", str(out), "--check"]) == 0
    out.write_text(out.read_text(encoding="utf-8").replace('"Gear"', '"Gera"'), encoding="utf-8")
    assert gen_vocab.main(["--output", str(out), "--check"]) == 1


def test_generator_escapes_python_keywords(gen_vocab: ModuleType) -> None:
    onto = Ontology.load(
        "@prefix owl: <http://www.w3.org/2002/07/owl#> .\n"
        "@prefix ex: <https://example.org/kw#> .\n"
        "@prefix skm: <https://skimesh.dev/ontology#> .\n"
        "ex:Thing2 a owl:Class . ex:in a owl:ObjectProperty . ex:is a owl:DatatypeProperty .\n"
        "ex:small-one a owl:NamedIndividual , ex:Thing2 ; skm:template true ."
    )
    text = gen_vocab.render(onto)
    assert '    in_: Final = "in"' in text
    assert '    is_: Final = "is"' in text
    assert '    small_one: Final = "small-one"' in text
    compile(text, "vocab.py", "exec")
