"""Generate the config-file references: ``docs/reference/<format>.md`` and
``docs/reference/schemas/<format>.schema.json`` for every TOML format the project reads, from
the msgspec Structs that decode them, so the references cannot drift from the code.

    python scripts/gen_reference.py            # rewrite every generated file
    python scripts/gen_reference.py --check    # exit 1 if any generated file is stale

Where the meaning of a key comes from (one convention, read by this script and by msgspec):

- the Struct's docstring: its text before ``Attributes:`` describes the table (msgspec puts a
  Struct's docstring into its JSON Schema ``description``); its ``Attributes:`` section has one
  entry per key, ``name (unit): meaning`` (the unit is optional), continuation lines indented;
- for Structs defined elsewhere (wire structs, ``device_drivers.Pose2D``), a ``Keys:`` section
  in the docstring of a module named in :data:`FORMATS`, entries ``Class.name (unit): meaning``;
- else an attribute docstring under the field (``x: float = 0`` then ``\"\"\"...\"\"\"``), or a
  ``Meta(description=...)`` on its type (``x-unit`` in ``Meta(extra_json_schema=...)``).

Types, defaults, ranges and choices come from ``msgspec.json.schema``. The JSON Schemas are
written as JSON Schema draft 4 (the draft Taplo, the engine of VS Code's Even Better TOML,
implements). ``tests/unit/test_reference.py`` fails while a generated file is stale.
"""

from __future__ import annotations

import argparse
import ast
import difflib
import importlib
import inspect
import itertools
import json
import re
import sys
import textwrap
from collections.abc import Iterator, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import msgspec

ROOT = Path(__file__).resolve().parent.parent
OUT = ROOT / "docs" / "reference"
COMMAND = "python scripts/gen_reference.py"
DRAFT4 = "http://json-schema.org/draft-04/schema#"

Schema = dict[str, Any]


@dataclass(frozen=True)
class Format:
    """One config file format: the Struct that decodes it and where it is used."""

    slug: str
    title: str
    root: str
    """``module:Struct`` of the top-level table."""
    docs: tuple[str, ...]
    """Modules whose docstring ``Keys:`` section describes Structs defined elsewhere."""
    examples: tuple[str, ...]
    """Globs (from the repository root) of the shipped files in this format."""
    complete: tuple[str, ...]
    """Modules whose Structs must give every key a meaning (the test checks it)."""
    intro: str


FORMATS: tuple[Format, ...] = (
    Format(
        slug="scenario",
        title="Scenario file",
        root="scenario:Scenario",
        docs=("scenario._schema",),
        examples=("configs/scenarios/*/scenario.toml",),
        complete=("scenario._schema", "scenario._robot_spec", "device_drivers._interfaces"),
        intro=(
            "A scenario file describes a simulated world: robots, furniture, containers, parts, "
            "appliances, sensors and goals. `skimesh wm`, `skimesh sim`, `skimesh agent` and "
            "`skimesh demo` read it with `--scenario NAME` (the file "
            "`configs/scenarios/NAME/scenario.toml`) or `--scenario FILE`; "
            "`scenario.load_scenario` decodes it strictly (an unknown key is an error naming its "
            "path, e.g. "
            "`$.parts[3].size`) and then checks references between elements.\n\n"
            "Frames: a child's `pose` is relative to its parent's *support surface* (a furniture "
            "top, a container's inner floor, a robot's deck, an appliance's cavity floor) and "
            "places the child's bottom centre; without a parent it is in the world frame, on the "
            "floor. "
            "Relative file paths (`agent`, MJCF files) are resolved against the scenario file."
        ),
    ),
    Format(
        slug="agent",
        title="Agent config file",
        root="skill_agent.runtime:AgentConfig",
        docs=("skill_agent.runtime._config",),
        examples=("configs/agents/**/*.toml",),
        complete=("skill_agent.runtime._config",),
        intro=(
            "The configuration of one skill agent: its name, robot, devices, skills and options. "
            "`skimesh agent --agent-config FILE` reads it, or `skimesh agent --scenario NAME "
            "--robot R` the file the scenario's robot (or appliance) names in `agent`; "
            "`skill_agent.runtime.load_config` decodes it strictly (an unknown key is an error "
            "naming its path, e.g. `$.robot.lable`). Relative paths (skill files, `event_log`, "
            "`ontology`) are relative to the config file."
        ),
    ),
    Format(
        slug="task",
        title="Task file",
        root="task_agent.protocol:TaskFile",
        docs=("task_agent.taskfile",),
        examples=("configs/tasks/*.toml",),
        complete=("task_agent.protocol",),
        intro=(
            "A hand-written task: a tree of `sequence` / `parallel` blocks whose leaves are skill "
            "`call`s, each block a table with a `block` key. `skimesh task verify FILE` checks it "
            "against the live mesh and `skimesh task submit --file FILE` runs it; "
            "`task_agent.taskfile.read_task_file` decodes it strictly (a wrong key or value names "
            "the line and the block, e.g. `root.1.0`). A block's *path* is its position (`root`, "
            "then child indices: `root.1.0`); a block without an `id` gets its path as id."
        ),
    ),
    Format(
        slug="site",
        title="Site file",
        root="skimesh.site:Site",
        docs=("skimesh.site._schema",),
        examples=("configs/sites/*.toml",),
        complete=("skimesh.site._schema",),
        intro=(
            "A site: its mesh, its hosts, and which host runs which process (routers, the "
            "world-model store, the simulator, the skill agents, the task agent). `skimesh up "
            "SITE.toml --host NAME` starts one host's processes in dependency order, each ready "
            "(a health probe) before the next, restarts them by the `[restart]` policy and "
            "stops them on Ctrl-C or `skimesh down SITE.toml`; `skimesh status SITE.toml` shows "
            "them (see the [site guide](../guides/site.md)). `skimesh.site.load_site` decodes "
            "the file strictly (an unknown key is an error naming its path, e.g. "
            "`$.store.dta`); `skimesh.site.make_plan` then checks hosts, the scenario, robots "
            "and ports. Relative paths (`zenoh_config`, agent `configs`, store `ontology`, a "
            "scenario file) are relative to the site file; `data` and `rerun` to the host's "
            "state directory."
        ),
    ),
)

ZENOH_NOTE = (
    "Zenoh's own JSON5 config files (`--config FILE`, examples in `configs/zenoh/`) are Zenoh's "
    "format: see [Zenoh's configuration documentation]"
    "(https://zenoh.io/docs/manual/configuration/) and its commented "
    "[DEFAULT_CONFIG.json5]"
    "(https://github.com/eclipse-zenoh/zenoh/blob/main/DEFAULT_CONFIG.json5); "
    "`configs/zenoh/README.md` explains the shipped ones."
)

# --------------------------------------------------------------------------- docs from code

_ENTRY = re.compile(r"^(?P<name>[A-Za-z_][\w.]*)(?: \((?P<unit>[^)]+)\))?: (?P<text>.*)$")
FieldDoc = tuple[str, str]
"""(unit, meaning) of one key."""


def _entries(section: str) -> dict[str, FieldDoc]:
    """``name (unit): text`` entries of a dedented section, continuation lines indented."""
    out: dict[str, FieldDoc] = {}
    name = ""
    for line in section.splitlines():
        if not line.strip():
            name = ""
            continue
        if line.startswith((" ", "\t")) and name:
            unit, text = out[name]
            out[name] = (unit, f"{text} {line.strip()}")
            continue
        match = _ENTRY.match(line)
        if match is None:
            name = ""
            continue
        name = match["name"]
        out[name] = (match["unit"] or "", match["text"].strip())
    return out


def _section(doc: str, heading: str) -> tuple[str, str]:
    """``doc`` (cleaned) split into the text before the section ``heading`` and that section's
    body (dedented). The heading line starts with ``heading`` and may run on until a line ending
    with ``:``; the body is the indented lines after it."""
    lines = inspect.cleandoc(doc).splitlines()
    start = next((i for i, line in enumerate(lines) if re.match(rf"{heading}\b", line)), None)
    if start is None:
        return "\n".join(lines).strip(), ""
    end = next((i for i in range(start, len(lines)) if lines[i].rstrip().endswith(":")), start)
    body: list[str] = []
    for line in lines[end + 1 :]:
        if line and not line.startswith((" ", "\t")):
            break
        body.append(line)
    return "\n".join(lines[:start]).strip(), textwrap.dedent("\n".join(body))


def struct_docs(cls: type) -> tuple[str, dict[str, FieldDoc]]:
    """The description of ``cls`` and its per-field docs (``Attributes:``, then attribute
    docstrings)."""
    summary, attributes = _section(cls.__doc__ or "", "Attributes")
    docs = _attribute_docstrings(cls)
    docs.update(_entries(attributes))
    return summary, docs


def _attribute_docstrings(cls: type) -> dict[str, FieldDoc]:
    try:
        tree = ast.parse(textwrap.dedent(inspect.getsource(cls)))
    except (OSError, TypeError):
        return {}
    body = tree.body[0].body if tree.body and isinstance(tree.body[0], ast.ClassDef) else []
    out: dict[str, FieldDoc] = {}
    for prev, node in itertools.pairwise(body):
        if (
            isinstance(prev, ast.AnnAssign)
            and isinstance(prev.target, ast.Name)
            and isinstance(node, ast.Expr)
            and isinstance(node.value, ast.Constant)
            and isinstance(node.value.value, str)
        ):
            out[prev.target.id] = ("", " ".join(node.value.value.split()))
    return out


def module_keys(module: str) -> dict[str, dict[str, FieldDoc]]:
    """``Class.field`` docs of a module docstring's ``Keys`` section, by class."""
    _, keys = _section(importlib.import_module(module).__doc__ or "", "Keys")
    out: dict[str, dict[str, FieldDoc]] = {}
    for dotted, doc in _entries(keys).items():
        cls, _, field = dotted.rpartition(".")
        if cls:
            out.setdefault(cls, {})[field] = doc
    return out


def structs(root: type) -> dict[str, type]:
    """Every Struct class reachable from ``root``, by name (as in the JSON Schema)."""
    found: dict[str, type] = {}

    def visit(info: msgspec.inspect.Type) -> None:
        if isinstance(info, msgspec.inspect.StructType):
            if info.cls.__name__ in found:
                return
            found[info.cls.__name__] = info.cls
            for field in info.fields:
                visit(field.type)
            return
        for attr in ("item_type", "value_type", "key_type", "type"):
            child = getattr(info, attr, None)
            if isinstance(child, msgspec.inspect.Type):
                visit(child)
        for attr in ("item_types", "types"):
            for child in getattr(info, attr, ()) or ():
                visit(child)

    visit(msgspec.inspect.type_info(root))
    return found


def load_root(fmt: Format) -> type:
    module, _, name = fmt.root.partition(":")
    cls = getattr(importlib.import_module(module), name)
    assert isinstance(cls, type)
    return cls


# --------------------------------------------------------------------------- the JSON Schema


@dataclass
class Documented:
    """A format's schema (msgspec's, with docs filled in) and where each Struct came from."""

    fmt: Format
    root: str
    defs: dict[str, Schema]
    units: dict[tuple[str, str], str]
    missing: list[str]
    """``Class.field`` without a meaning, of the Structs in ``fmt.complete``."""


def _rst(text: str) -> str:
    """reStructuredText roles and literals -> Markdown."""
    text = re.sub(r":(?:class|func|mod|data|meth|attr):`~?([^`]+)`", lambda m: f"`{m[1]}`", text)
    text = re.sub(r"``([^`]+)``", r"`\1`", text)
    return " ".join(text.split()) if "\n\n" not in text else text


def document(fmt: Format) -> Documented:
    root = load_root(fmt)
    _, components = msgspec.json.schema_components([root], ref_template="#/definitions/{name}")
    classes = structs(root)
    overlay: dict[str, dict[str, FieldDoc]] = {}
    for module in fmt.docs:
        for cls_name, docs in module_keys(module).items():
            overlay.setdefault(cls_name, {}).update(docs)
    units: dict[tuple[str, str], str] = {}
    missing: list[str] = []
    defs: dict[str, Schema] = _canonical(json.loads(json.dumps(components)))
    for name, schema in defs.items():
        cls = classes.get(name)
        if cls is None:
            continue
        summary, docs = struct_docs(cls)
        docs.update(overlay.get(name, {}))
        if summary:
            schema["description"] = _rst(summary)
        else:
            schema.pop("description", None)
        tag = _tag_field(schema)
        for key, prop in schema.get("properties", {}).items():
            unit, text = docs.get(key, ("", prop.get("description", "")))  # or Meta's
            if not text and key == tag:
                text = f"`{prop['enum'][0]}`: selects this kind of table."
            if text:
                prop["description"] = _rst(text)
            else:
                prop.pop("description", None)
                if cls.__module__ in fmt.complete:
                    missing.append(f"{name}.{key}")
            unit = unit or prop.get("x-unit", "")
            if unit:
                units[(name, key)] = unit
                prop["x-unit"] = unit
    return Documented(fmt, root.__name__, defs, units, missing)


_BOUNDS = ("minimum", "maximum", "exclusiveMinimum", "exclusiveMaximum")


def _canonical(node: Any) -> Any:
    """Bounds as written by the first equal ``Meta`` Python created (``typing`` caches equal
    ``Annotated`` types, and ``Meta(ge=0) == Meta(ge=0.0)``), made independent of import
    order: a whole-number bound is an integer."""
    if isinstance(node, list):
        return [_canonical(n) for n in node]
    if not isinstance(node, dict):
        return node
    out = {k: _canonical(v) for k, v in node.items()}
    for key in _BOUNDS:
        value = out.get(key)
        if isinstance(value, float) and value.is_integer():
            out[key] = int(value)
    return out


def _tag_field(schema: Schema) -> str:
    """The tag key of a tagged Struct (a property whose only allowed value is one string)."""
    for key, prop in schema.get("properties", {}).items():
        if key in schema.get("required", ()) and len(prop.get("enum", ())) == 1:
            return str(key)
    return ""


def _draft4(node: Any) -> Any:
    """msgspec's JSON Schema (2020-12) rewritten with draft-4 keywords."""
    if isinstance(node, list):
        return [_draft4(n) for n in node]
    if not isinstance(node, dict):
        return node
    out: Schema = {k: _draft4(v) for k, v in node.items() if k != "discriminator"}
    if "prefixItems" in out:
        out["items"] = out.pop("prefixItems")
        out["additionalItems"] = False
    for bound, limit in (("exclusiveMinimum", "minimum"), ("exclusiveMaximum", "maximum")):
        if isinstance(out.get(bound), int | float) and not isinstance(out.get(bound), bool):
            out[limit] = out[bound]
            out[bound] = True
    if "$ref" in out and len(out) > 1:  # draft 4 ignores the siblings of $ref
        ref = out.pop("$ref")
        out["allOf"] = [{"$ref": ref}]
    if "description" in out and "x-unit" in out:
        out["description"] = f"{out['description']} Unit: {out['x-unit']}."
    return out


def json_schema(doc: Documented) -> str:
    defs = _draft4(doc.defs)
    top: Schema = {"$schema": DRAFT4, "title": doc.fmt.title}
    top.update({k: v for k, v in defs[doc.root].items() if k != "title"})
    top["definitions"] = defs
    return json.dumps(top, indent=2, ensure_ascii=False) + "\n"


# --------------------------------------------------------------------------- the Markdown page


def _toml(value: Any) -> str:
    if value is None:
        return "none"
    if isinstance(value, bool):
        return "true" if value else "false"
    if isinstance(value, str):
        return json.dumps(value, ensure_ascii=False)
    if isinstance(value, list):
        return "[" + ", ".join(_toml(v) for v in value) + "]"
    if isinstance(value, dict):
        inner = ", ".join(f"{k} = {_toml(v)}" for k, v in value.items())
        return "{ " + inner + " }" if inner else "{}"
    return repr(value)


def _refs(schema: Schema) -> Iterator[str]:
    if "$ref" in schema:
        yield schema["$ref"].rpartition("/")[2]
    for member in schema.get("anyOf", ()):
        yield from _refs(member)


def _is_value(schema: Schema) -> bool:
    """A world-model value: a scalar, a list, or a typed value table (``wm_store`` Value)."""
    kinds = {m.get("type") for m in schema.get("anyOf", ())}
    return {"boolean", "string", "number", "array"} <= kinds


def _type(schema: Schema) -> str:
    if _is_value(schema):
        return "[value](#values)"
    if "$ref" in schema:
        name = schema["$ref"].rpartition("/")[2]
        return f"table ([{name}](#{name.lower()}))"
    if "anyOf" in schema:
        members = [m for m in schema["anyOf"] if m.get("type") != "null"]
        if len(members) > 1 and all("$ref" in m for m in members):
            names = [f"[{n}](#{n.lower()})" for n in _refs(schema)]
            return "table: " + ", ".join(names[:-1]) + " or " + names[-1]
        return " or ".join(dict.fromkeys(_type(m) for m in members))
    if "enum" in schema:
        return "integer" if all(isinstance(v, int) for v in schema["enum"]) else "string"
    kind = schema.get("type")
    if kind == "array":
        if "prefixItems" in schema:
            return "[" + ", ".join(_type(m) for m in schema["prefixItems"]) + "]"
        item = _type(schema.get("items", {}))
        return "array of tables" + item[5:] if item.startswith("table") else f"array of {item}"
    if kind == "object":
        return f"table of {_type(schema.get('additionalProperties', {}))}"
    return {"number": "float", "integer": "integer", "boolean": "boolean", "string": "string"}.get(
        str(kind), "any"
    )


def _bounds(schema: Schema) -> str:
    low = (
        f"{schema['minimum']} ≤ "
        if "minimum" in schema
        else f"{schema['exclusiveMinimum']} < "
        if "exclusiveMinimum" in schema
        else ""
    )
    high = (
        f" ≤ {schema['maximum']}"
        if "maximum" in schema
        else f" < {schema['exclusiveMaximum']}"
        if "exclusiveMaximum" in schema
        else ""
    )
    return f"{low}x{high}" if low or high else ""


def _allowed(schema: Schema) -> str:
    parts: list[str] = []
    members = [m for m in schema.get("anyOf", ()) if m.get("type") != "null"]
    if len(members) == 1 and not _is_value(schema):
        schema = members[0]
    if "enum" in schema:
        parts.append(", ".join(f"`{_toml(v)}`" for v in schema["enum"]))
    if bounds := _bounds(schema):
        parts.append(bounds)
    if "pattern" in schema:
        parts.append(f"matches `{schema['pattern']}`")
    if "maxLength" in schema:
        parts.append(f"at most {schema['maxLength']} characters")
    if schema.get("type") == "array":
        items = schema.get("prefixItems") or [schema.get("items", {})]
        if "prefixItems" not in schema and "minItems" in schema:
            parts.append(f"at least {schema['minItems']} items")
        inner = {_allowed(m) for m in items if isinstance(m, dict)} - {""}
        if len(inner) == 1:
            parts.append(f"each {inner.pop()}")
    return "; ".join(parts)


def _cell(text: str) -> str:
    return text.replace("|", "\\|").replace("\n", " ") or "—"


@dataclass
class Table:
    name: str
    paths: list[str]
    """TOML headers that reach it (``[[robots]]``, ``[robots.model]``), at most four."""
    base: str
    """Dotted key path of the first header (``robots.model``)."""


def _tables(doc: Documented) -> tuple[list[Table], list[str]]:
    """The format's tables in breadth-first order with the TOML paths that reach them, and
    the value tables (typed world-model values)."""
    order: dict[str, Table] = {doc.root: Table(doc.root, [""], "")}
    values: list[str] = []
    queue = [doc.root]
    while queue:
        name = queue.pop(0)
        parent = order[name].base
        for key, prop in doc.defs[name].get("properties", {}).items():
            path = f"{parent}.{key}" if parent else key
            targets: list[tuple[str, str]] = []
            if _is_value(prop) or _is_value(prop.get("additionalProperties", {})):
                inner = prop.get("additionalProperties", prop)
                values += [r for r in _refs(inner) if r not in values]
                continue
            if prop.get("type") == "array" and isinstance(prop.get("items"), dict):
                targets = [(r, f"[[{path}]]") for r in _refs(prop["items"])]
            elif prop.get("type") == "object":
                sub = f"{path}.<name>"
                targets = [(r, f"[{sub}]") for r in _refs(prop.get("additionalProperties", {}))]
            else:
                targets = [(r, f"[{path}]") for r in _refs(prop)]
            for ref, header in targets:
                if ref not in order:
                    order[ref] = Table(ref, [], header.strip("[]"))
                    queue.append(ref)
                if len(order[ref].paths) < 4 and header not in order[ref].paths:
                    order[ref].paths.append(header)
    return list(order.values()), [v for v in values if v not in order]


def _rows(doc: Documented, name: str) -> list[str]:
    schema = doc.defs[name]
    required = set(schema.get("required", ()))
    rows = [
        "| key | type | unit | default | allowed | meaning |",
        "|---|---|---|---|---|---|",
    ]
    for key, prop in schema.get("properties", {}).items():
        default = "**required**" if key in required else f"`{_toml(prop.get('default'))}`"
        if key not in required and prop.get("default") is None:
            default = "none (leave out)"
        elif isinstance(prop.get("default"), dict) and prop["default"]:
            default = "its keys' defaults"
        rows.append(
            "| "
            + " | ".join(
                [
                    f"`{key}`",
                    _cell(_type(prop)),
                    _cell(doc.units.get((name, key), "")),
                    _cell(default),
                    _cell(_allowed(prop)),
                    _cell(prop.get("description", "")),
                ]
            )
            + " |"
        )
    return rows


def _editor(fmt: Format, example: str) -> list[str]:
    schema = f"docs/reference/schemas/{fmt.slug}.schema.json"
    depth = example.count("/")
    relative = "../" * depth + schema
    return [
        "## Editor support",
        "",
        f"[`schemas/{fmt.slug}.schema.json`](schemas/{fmt.slug}.schema.json) is this format as "
        "a JSON Schema (draft 4, the draft Taplo implements): an editor that knows it completes "
        "keys, shows these meanings on hover and marks unknown keys, wrong types and values out "
        "of range.",
        "",
        "- **VS Code with Even Better TOML, or any editor using Taplo (or Tombi)**: put a schema "
        "directive at the top of the file, before any key (a path relative to the file, or a "
        "URL):",
        "",
        "  ```toml",
        f"  #:schema {relative}",
        "  ```",
        "",
        "  or associate the schema with files by a rule in a `.taplo.toml` at the repository "
        "root (no edit of the files):",
        "",
        "  ```toml",
        "  [[rule]]",
        f'  include = ["{fmt.examples[0]}"]',
        "  [rule.schema]",
        f'  path = "{schema}"',
        "  ```",
        "",
        f"- **Taplo on the command line**: `taplo lint --schema file://$PWD/{schema} {example}`.",
        "",
        "The loader stays the authority: it also checks what a JSON Schema cannot say "
        "(references between elements, a sphere's one-element `size`, ...).",
        "",
    ]


def markdown(doc: Documented) -> str:
    fmt = doc.fmt
    examples = sorted(
        str(p.relative_to(ROOT)) for pattern in fmt.examples for p in ROOT.glob(pattern)
    )
    tables, values = _tables(doc)
    lines = [
        f"# {fmt.title} reference",
        "",
        f"<!-- Generated by `{COMMAND}` from `{fmt.root}`; do not edit by hand. -->",
        "",
        fmt.intro,
        "",
        "Shipped examples: " + ", ".join(f"[`{e}`](../../{e})" for e in examples) + ".",
        "",
        "Each table below lists its keys with their TOML type, unit, default (**required** keys "
        "have none; *none* means the key is simply left out), the values allowed and their "
        "meaning. A table can also be written inline (`pose = { x = 1.0, y = 2.0 }`); "
        "`[[name]]` is an array of tables (one `[[name]]` header per element).",
        "",
        *_editor(fmt, examples[0] if examples else fmt.examples[0]),
        "## Keys",
        "",
    ]
    for table in tables:
        title = (
            "Top level"
            if table.paths == [""]
            else ", ".join(f"`{p}`" for p in table.paths if p) or table.name
        )
        if tag := _tag_field(doc.defs[table.name]):
            title += f' with `{tag} = "{doc.defs[table.name]["properties"][tag]["enum"][0]}"`'
        lines += [f'<a id="{table.name.lower()}"></a>', "", f"### {title}", ""]
        description = doc.defs[table.name].get("description", "")
        lines += [f"`{table.name}`" + (f": {description}" if description else ""), ""]
        lines += [*_rows(doc, table.name), ""]
    if values:
        lines += [
            '<a id="values"></a>',
            "",
            "## Values",
            "",
            "A *value* (skill parameters, element properties) is a boolean, an integer, a float, "
            "a string, an array of values, or a typed table whose `type` key names one of the "
            'tables below, e.g. `{ type = "Position", x = 0.1, y = 0.0, z = 0.7 }`.',
            "",
        ]
        for name in values:
            description = doc.defs[name].get("description", "")
            lines += [f'<a id="{name.lower()}"></a>', "", f"### {name}", ""]
            if description:
                lines += [description, ""]
            lines += [*_rows(doc, name), ""]
    return "\n".join(lines).rstrip() + "\n"


def index() -> str:
    lines = [
        "# Config file reference",
        "",
        f"<!-- Generated by `{COMMAND}`; do not edit by hand. -->",
        "",
        "Every TOML file skimesh reads, with every key: type, unit, default, allowed values and "
        "meaning, and a JSON Schema per format for editors (completion, hover docs, validation).",
        "",
        "| format | reference | JSON Schema | shipped examples |",
        "|---|---|---|---|",
    ]
    for fmt in FORMATS:
        lines.append(
            f"| {fmt.title} | [{fmt.slug}.md]({fmt.slug}.md) | "
            f"[schemas/{fmt.slug}.schema.json](schemas/{fmt.slug}.schema.json) | "
            + ", ".join(f"`{g}`" for g in fmt.examples)
            + " |"
        )
    lines += [
        "",
        ZENOH_NOTE,
        "",
        "## How these files are made",
        "",
        f"`{COMMAND}` writes every file here from the msgspec Structs that decode the formats "
        f"(`{COMMAND} --check` only tells whether one is stale; `tests/unit/test_reference.py` "
        "fails while one is). Re-run it after changing a schema. Types, defaults, ranges and "
        "choices come from `msgspec.json.schema`; meanings and units from the Structs' "
        "docstrings, one convention for all:",
        "",
        "```python",
        "class Placement(Struct, frozen=True, forbid_unknown_fields=True):",
        '    """Where an element stands (this text describes the table).',
        "",
        "    Attributes:",
        "        x (m): Along the parent's x axis.",
        "        yaw (rad): Turn about +z, counter-clockwise seen from above.",
        '    """',
        "",
        "    x: Coord = 0.0",
        "    yaw: float = 0.0",
        "```",
        "",
        "Each `Attributes:` entry is `key (unit): meaning`, the unit optional, continuation "
        "lines indented. A Struct defined outside the format's package (a wire struct such as "
        "the task blocks, `device_drivers.Pose2D`) is described in a `Keys:` section of the "
        "format module's docstring, entries `Class.key (unit): meaning` (see "
        "`task_agent/taskfile.py`). A key without a meaning fails `tests/unit/test_reference.py`.",
        "",
    ]
    return "\n".join(lines)


# --------------------------------------------------------------------------- files


def outputs() -> dict[Path, str]:
    """Every generated file and its content."""
    files = {OUT / "README.md": index()}
    for fmt in FORMATS:
        doc = document(fmt)
        files[OUT / f"{fmt.slug}.md"] = markdown(doc)
        files[OUT / "schemas" / f"{fmt.slug}.schema.json"] = json_schema(doc)
    return files


def stale(files: dict[Path, str]) -> list[Path]:
    return [
        path
        for path, text in files.items()
        if not path.exists() or path.read_text(encoding="utf-8") != text
    ]


def _show(path: Path) -> str:
    return str(path.relative_to(ROOT)) if path.is_relative_to(ROOT) else str(path)


def main(argv: Sequence[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0] if __doc__ else None)
    parser.add_argument("--check", action="store_true", help="exit 1 if a file is stale")
    args = parser.parse_args(argv)
    files = outputs()
    old = stale(files)
    if args.check:
        for path in old:
            before = path.read_text(encoding="utf-8").splitlines() if path.exists() else []
            diff = difflib.unified_diff(before, files[path].splitlines(), str(path), "generated")
            sys.stdout.write("\n".join(list(diff)[:40]) + "\n")
        if old:
            print(f"stale: {', '.join(_show(p) for p in old)}; run `{COMMAND}`")
        return 1 if old else 0
    for path in old:
        path.parent.mkdir(parents=True, exist_ok=True)
        path.write_text(files[path], encoding="utf-8")
        print(f"wrote {_show(path)}")
    return 0


if __name__ == "__main__":
    sys.path.insert(0, str(ROOT))
    sys.exit(main())
