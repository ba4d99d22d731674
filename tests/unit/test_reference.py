"""The config-file references (``docs/reference``) are generated from the schemas by
``scripts/gen_reference.py`` and must stay in step with them; every shipped config must
validate against its JSON Schema and decode with its loader."""

from __future__ import annotations

import importlib.util
import json
import re
import sys
import tomllib
from collections.abc import Callable, Iterator
from pathlib import Path
from types import ModuleType
from typing import Any

import msgspec
import pytest

from scenario import load_scenario
from skill_agent.runtime import load_config
from skimesh.site import load_site
from task_agent.taskfile import read_task_file

ROOT = Path(__file__).resolve().parents[2]
REGENERATE = "python scripts/gen_reference.py"


def _load_generator() -> ModuleType:
    spec = importlib.util.spec_from_file_location(
        "gen_reference", ROOT / "scripts" / "gen_reference.py"
    )
    assert spec is not None
    assert spec.loader is not None
    module = importlib.util.module_from_spec(spec)
    sys.modules.setdefault("gen_reference", module)  # dataclasses look their module up
    spec.loader.exec_module(module)
    return module


GEN = _load_generator()
LOADERS: dict[str, Callable[[Path], object]] = {
    "scenario": load_scenario,
    "agent": load_config,
    "task": read_task_file,
    "site": load_site,
}


@pytest.fixture(scope="module")
def generated() -> dict[Path, str]:
    files: dict[Path, str] = GEN.outputs()
    return files


def _schema(slug: str) -> dict[str, Any]:
    path = ROOT / "docs" / "reference" / "schemas" / f"{slug}.schema.json"
    loaded: dict[str, Any] = json.loads(path.read_text(encoding="utf-8"))
    return loaded


def _shipped(slug: str) -> list[Path]:
    fmt = next(f for f in GEN.FORMATS if f.slug == slug)
    return sorted(p for pattern in fmt.examples for p in ROOT.glob(pattern))


# --------------------------------------------------------------------------- up to date


def test_every_generated_file_is_up_to_date(generated: dict[Path, str]) -> None:
    stale = [
        str(path.relative_to(ROOT))
        for path, text in generated.items()
        if not path.exists() or path.read_text(encoding="utf-8") != text
    ]
    assert not stale, f"stale generated reference files {stale}: run `{REGENERATE}`"


def test_every_format_has_a_page_a_schema_and_a_loader(generated: dict[Path, str]) -> None:
    slugs = {f.slug for f in GEN.FORMATS}
    assert slugs == set(LOADERS)
    names = {p.name for p in generated}
    for slug in slugs:
        assert {f"{slug}.md", f"{slug}.schema.json"} <= names
    index = generated[ROOT / "docs" / "reference" / "README.md"]
    assert all(f"({slug}.md)" in index for slug in slugs)


def test_check_mode_detects_a_stale_file(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setattr(GEN, "OUT", tmp_path)
    assert GEN.main(["--check"]) == 1  # nothing there yet
    assert GEN.main([]) == 0
    assert GEN.main(["--check"]) == 0
    page = tmp_path / "scenario.md"
    page.write_text(page.read_text(encoding="utf-8") + "edited by hand\n", encoding="utf-8")
    assert GEN.main(["--check"]) == 1


# --------------------------------------------------------------------------- meanings


@pytest.mark.parametrize("fmt", GEN.FORMATS, ids=lambda f: f.slug)
def test_every_key_of_the_formats_own_structs_has_a_meaning(fmt: Any) -> None:
    doc = GEN.document(fmt)
    assert not doc.missing, (
        f"keys without a meaning: {doc.missing}; describe them in the Struct's docstring "
        "(`Attributes:` entries `name (unit): meaning`), then run `" + REGENERATE + "`"
    )


def _property(schema: dict[str, Any], struct: str, key: str) -> dict[str, Any]:
    prop: dict[str, Any] = schema["definitions"][struct]["properties"][key]
    return prop


@pytest.mark.parametrize(
    ("slug", "struct", "key", "unit", "words"),
    [
        ("scenario", "FurnitureEntry", "pose", "", "faces"),  # a station's yaw
        ("scenario", "FurnitureEntry", "station", "", "station"),
        ("scenario", "ContainerEntry", "fixed", "", "never moves"),
        ("scenario", "SensorEntry", "occlusion", "", "hidden"),
        ("scenario", "SensorEntry", "noise_std", "m", "Standard deviation"),
        ("scenario", "SensorEntry", "fov", "deg", "field of view"),
        ("scenario", "Pose2D", "yaw", "rad", "about +z"),
        ("scenario", "MjcfArm", "home", "rad", "Home posture"),
        ("agent", "AgentConfig", "ontology", "", "Turtle"),
        ("agent", "AgentConfig", "preempt_timeout", "s", "on_preempt"),
        ("task", "Call", "params", "", "label:"),
    ],
)
def test_the_schema_carries_meanings_and_units(
    slug: str, struct: str, key: str, unit: str, words: str
) -> None:
    prop = _property(_schema(slug), struct, key)
    assert words in prop["description"]
    assert prop.get("x-unit", "") == unit


class _Documented(msgspec.Struct):
    """A table.

    Attributes:
        a (s): From the docstring.
    """

    a: float = 0.0
    b: int = 0
    """From an attribute docstring."""


def test_struct_docs_read_attributes_then_attribute_docstrings() -> None:
    summary, docs = GEN.struct_docs(_Documented)
    assert summary == "A table."
    assert docs == {"a": ("s", "From the docstring."), "b": ("", "From an attribute docstring.")}


def test_docstring_entries_parse_units_and_continuations() -> None:
    entries = GEN._entries("a (m/s): Fast.\n    Really.\nb: Plain.\nnot an entry\n")
    assert entries == {"a": ("m/s", "Fast. Really."), "b": ("", "Plain.")}


# --------------------------------------------------------------------------- validation

_DRAFT4_KEYWORDS = {
    "$schema", "$ref", "title", "description", "default", "type", "properties", "required",
    "additionalProperties", "items", "additionalItems", "minItems", "maxItems", "enum",
    "minimum", "maximum", "exclusiveMinimum", "exclusiveMaximum", "pattern", "minLength",
    "maxLength", "anyOf", "allOf", "oneOf", "not", "definitions", "format",
}  # fmt: skip
_TYPES = {"object", "array", "string", "number", "integer", "boolean", "null"}


def _nodes(node: Any, path: str = "#") -> Iterator[tuple[str, dict[str, Any]]]:
    if isinstance(node, dict):
        yield path, node
        for key, value in node.items():
            if key in ("properties", "definitions"):
                for name, sub in value.items():
                    yield from _nodes(sub, f"{path}/{key}/{name}")
            elif key not in ("default", "enum") and isinstance(value, dict | list):
                yield from _nodes(value, f"{path}/{key}")
    elif isinstance(node, list):
        for i, item in enumerate(node):
            yield from _nodes(item, f"{path}/{i}")


@pytest.mark.parametrize("slug", sorted(LOADERS))
def test_the_json_schema_is_well_formed_draft_4(slug: str) -> None:
    schema = _schema(slug)
    assert schema["$schema"] == "http://json-schema.org/draft-04/schema#"
    for where, node in _nodes(schema):
        unknown = {k for k in node if k not in _DRAFT4_KEYWORDS and not k.startswith("x-")}
        assert not unknown, f"{slug}: {where} uses non-draft-4 keywords {unknown}"
        if "$ref" in node:
            assert set(node) == {"$ref"}, f"{slug}: {where}: draft 4 ignores siblings of $ref"
            name = node["$ref"].removeprefix("#/definitions/")
            assert name in schema["definitions"], f"{slug}: {where}: dangling {node['$ref']}"
        if "type" in node:
            assert node["type"] in _TYPES, f"{slug}: {where}: type {node['type']!r}"
        for bound in ("exclusiveMinimum", "exclusiveMaximum"):
            assert isinstance(node.get(bound, True), bool), f"{slug}: {where}: {bound}"
        if "pattern" in node:
            re.compile(node["pattern"])


def _errors(schema: dict[str, Any], node: dict[str, Any], value: Any, at: str) -> list[str]:
    """A draft-4 validator for the keywords the generated schemas use."""
    if "$ref" in node:
        return _errors(schema, schema["definitions"][node["$ref"].rpartition("/")[2]], value, at)
    errors: list[str] = []
    for sub in node.get("allOf", ()):
        errors += _errors(schema, sub, value, at)
    if "anyOf" in node and all(_errors(schema, sub, value, at) for sub in node["anyOf"]):
        errors.append(f"{at}: matches none of its alternatives")
    kind = node.get("type")
    checks = {
        "object": isinstance(value, dict),
        "array": isinstance(value, list),
        "string": isinstance(value, str),
        "boolean": isinstance(value, bool),
        "integer": isinstance(value, int) and not isinstance(value, bool),
        "number": isinstance(value, int | float) and not isinstance(value, bool),
        "null": value is None,
    }
    if kind is not None and not checks[kind]:
        return [*errors, f"{at}: not a {kind}"]
    if "enum" in node and value not in node["enum"]:
        errors.append(f"{at}: {value!r} not one of {node['enum']}")
    if isinstance(value, int | float) and not isinstance(value, bool):
        if "minimum" in node and (
            value <= node["minimum"] if node.get("exclusiveMinimum") else value < node["minimum"]
        ):
            errors.append(f"{at}: {value} below the minimum {node['minimum']}")
        if "maximum" in node and (
            value >= node["maximum"] if node.get("exclusiveMaximum") else value > node["maximum"]
        ):
            errors.append(f"{at}: {value} above the maximum {node['maximum']}")
    if isinstance(value, str):
        if "pattern" in node and not re.search(node["pattern"], value):
            errors.append(f"{at}: {value!r} does not match {node['pattern']}")
        if len(value) > node.get("maxLength", len(value)):
            errors.append(f"{at}: longer than {node['maxLength']}")
    if isinstance(value, list):
        if not node.get("minItems", 0) <= len(value) <= node.get("maxItems", len(value)):
            errors.append(f"{at}: {len(value)} items")
        items = node.get("items", {})
        if isinstance(items, list):
            if node.get("additionalItems") is False and len(value) > len(items):
                errors.append(f"{at}: more than {len(items)} items")
            for i, (sub, item) in enumerate(zip(items, value, strict=False)):
                errors += _errors(schema, sub, item, f"{at}[{i}]")
        else:
            for i, item in enumerate(value):
                errors += _errors(schema, items, item, f"{at}[{i}]")
    if isinstance(value, dict):
        props = node.get("properties", {})
        errors += [f"{at}: missing {k}" for k in node.get("required", ()) if k not in value]
        for key, item in value.items():
            where = f"{at}.{key}"
            if key in props:
                errors += _errors(schema, props[key], item, where)
            elif node.get("additionalProperties") is False:
                errors.append(f"{where}: unknown key")
            elif isinstance(node.get("additionalProperties"), dict):
                errors += _errors(schema, node["additionalProperties"], item, where)
    return errors


def _validate(slug: str, document: Any) -> list[str]:
    schema = _schema(slug)
    return _errors(schema, schema, document, "$")


SHIPPED = [(slug, path) for slug in sorted(LOADERS) for path in _shipped(slug)]


@pytest.mark.parametrize(
    ("slug", "path"), SHIPPED, ids=[str(p.relative_to(ROOT)) for _, p in SHIPPED]
)
def test_every_shipped_config_validates_against_its_schema_and_loads(slug: str, path: Path) -> None:
    document = tomllib.loads(path.read_text(encoding="utf-8"))
    assert _validate(slug, document) == [], f"{path} against schemas/{slug}.schema.json"
    LOADERS[slug](path)  # what the programs do with it


def test_each_format_ships_examples() -> None:
    assert {slug for slug, _ in SHIPPED} == set(LOADERS)


@pytest.mark.parametrize(
    ("slug", "text", "error"),
    [
        ("scenario", 'name = "s"\nfloor_size = 500\n', "$.floor_size: 500 above the maximum"),
        ("scenario", 'name = "s"\n[[robots]]\nnme = "r1"\n', "$.robots[0]: missing name"),
        ("scenario", 'name = "has space"\n', "does not match"),
        (
            "scenario",
            'name = "s"\n[[sensors]]\nkind = "lidar"\nlabel = "L"\n',
            "$.sensors[0].kind: 'lidar' not one of",
        ),
        ("agent", 'name = "a"\n[robot]\nlable = "x"\n', "$.robot.lable: unknown key"),
        ("agent", 'name = "a"\nontology = "one.ttl"\n', "$.ontology: not a array"),
        ("task", 'name = "t"\n[root]\nblock = "loop"\n', "$.root: matches none"),
    ],
)
def test_the_schema_rejects_what_the_loader_rejects(slug: str, text: str, error: str) -> None:
    errors = _validate(slug, tomllib.loads(text))
    assert any(e.startswith(error) or error in e for e in errors), errors
