"""Hand-written task files: load them from TOML, give every block an id, walk their calls.

A task file (:class:`~task_agent.protocol.TaskFile`) is a tree of ``sequence`` / ``parallel``
blocks whose leaves are skill ``call`` s. :func:`load_task_file` reads the TOML text strictly:
a syntax error names the line; a wrong value names msgspec's path (``$.root.children[1].skill``),
the block (``root.1``) and, when it can be found, the line; an unknown key in a block (a typo
that msgspec's tolerant wire structs would drop silently) is an error naming the closest field.

**Paths and ids.** A block's *path* is its position: ``root`` for the root, then the child
indices, ``root.1.0`` = the first child of the second child of the root. A block without an
``id`` gets its path as id, so every block can be named in ``@<step id>.<param>``
references and in verification problems (:func:`where` writes ``root.1.0 (pick1)`` for an
explicit id).

**Order.** :func:`walk` lists every call in document order with what may run at the same time
as it. Two calls are *ordered* (:func:`precedes`) when the innermost block holding both is a
sequence: the one in the earlier child finishes before the other starts. When that block is a
parallel one they are *concurrent*. Pure: no I/O except :func:`read_task_file`.

Keys (of the wire structs in :mod:`task_agent.protocol`; ``scripts/gen_reference.py`` reads them
for the task-file reference):
    TaskFile.name: The task's name, shown in ``skimesh task`` listings and events.
    TaskFile.root: The root block: ``block = "call"``, ``"sequence"`` or ``"parallel"``.
    Call.block: ``"call"``: this block runs one skill.
    Call.skill: Name of the skill to run (or its family, e.g. ``pick``).
    Call.agent: Agent that runs it; empty: any agent offering ``skill``.
    Call.params: Skill parameters by name: a value, an element id, ``"label:<label>"`` (the
        element with that label) or ``"@<step id>.<param>"`` (the value an earlier step ran
        with). Parameters left out are inferred when the step starts.
    Call.id: Step id for ``@<id>.<param>`` references and messages; default: the block's path
        (``root.1.0``).
    Call.fallback_operator: If the skill fails, ask the operator to do it (semi-autonomy).
    Sequence.block: ``"sequence"``: the children run one after the other.
    Sequence.children: The child blocks, in order (``[[...children]]`` tables).
    Sequence.id: Block id; default: the block's path.
    Parallel.block: ``"parallel"``: the children run at the same time.
    Parallel.children: The child blocks (``[[...children]]`` tables).
    Parallel.id: Block id; default: the block's path.
"""

from __future__ import annotations

import re
import tomllib
from collections.abc import Iterator
from pathlib import Path
from typing import Any, Literal, NamedTuple

import msgspec

from wm_store.ontology import did_you_mean
from wm_store.protocol import Value

from ._errors import VerificationError
from .protocol import Call, Parallel, Sequence, TaskBlock, TaskFile

__all__ = [
    "LABEL_PREFIX",
    "REF_PREFIX",
    "ROOT_PATH",
    "BlockSite",
    "CallSite",
    "Ref",
    "assign_ids",
    "blocks",
    "load_task_file",
    "parse_ref",
    "precedes",
    "read_task_file",
    "walk",
    "where",
]

ROOT_PATH = "root"
"""The root block's path (and its key in the TOML file)."""
REF_PREFIX = "@"
"""``@<step id>.<param>``: the value that step ran with (data flow)."""
LABEL_PREFIX = "label:"
"""``label:<label>``: the element with that label (element parameters only)."""

Step = tuple[Literal["sequence", "parallel"], int]
"""One level of a position: the kind of the enclosing block and the child's index in it."""


class BlockSite(NamedTuple):
    """A block with its path, its position (``trail``) and its index in document order."""

    path: str
    block: TaskBlock
    trail: tuple[Step, ...]
    order: int


class CallSite(NamedTuple):
    """A call with its path, position, document order and the paths of the calls that may
    run at the same time as it (in document order)."""

    path: str
    call: Call
    trail: tuple[Step, ...]
    order: int
    parallel: tuple[str, ...]


class Ref(NamedTuple):
    """A parsed ``@<step>.<param>``; ``param`` is empty when the text has no dot."""

    step: str
    param: str


def parse_ref(value: Value) -> Ref | None:
    """The data-flow reference ``value`` is, or None if it is a plain value. The step id is
    everything before the last dot (positional ids contain dots)."""
    if not isinstance(value, str) or not value.startswith(REF_PREFIX):
        return None
    step, _, param = value[len(REF_PREFIX) :].rpartition(".")
    return Ref(step, param) if step else Ref(param, "")


def where(path: str, block: TaskBlock) -> str:
    """``root.1`` for a block named by its position, ``root.1 (pick1)`` for an explicit id."""
    return path if not block.id or block.id == path else f"{path} ({block.id})"


# --------------------------------------------------------------------------- ids and walking


def _with_ids(block: TaskBlock, path: str) -> TaskBlock:
    bid = block.id or path
    if isinstance(block, Call):
        return block if block.id else msgspec.structs.replace(block, id=bid)
    children = [_with_ids(c, f"{path}.{i}") for i, c in enumerate(block.children)]
    return msgspec.structs.replace(block, id=bid, children=children)


def assign_ids(task: TaskFile) -> TaskFile:
    """The task with every block that has no id named by its path (idempotent)."""
    return msgspec.structs.replace(task, root=_with_ids(task.root, ROOT_PATH))


def _blocks(block: TaskBlock, path: str, trail: tuple[Step, ...]) -> Iterator[BlockSite]:
    yield BlockSite(path, block, trail, 0)
    if isinstance(block, Call):
        return
    kind: Literal["sequence", "parallel"] = (
        "sequence" if isinstance(block, Sequence) else "parallel"
    )
    for i, child in enumerate(block.children):
        yield from _blocks(child, f"{path}.{i}", (*trail, (kind, i)))


def blocks(task: TaskFile) -> list[BlockSite]:
    """Every block, depth first (a block before its children), with its document order."""
    return [site._replace(order=i) for i, site in enumerate(_blocks(task.root, ROOT_PATH, ()))]


def _relation(a: tuple[Step, ...], b: tuple[Step, ...]) -> tuple[str, int, int]:
    """The kind of the innermost block holding both positions and the child index of each."""
    for (kind, i), (_, j) in zip(a, b, strict=False):
        if i != j:
            return kind, i, j
    return "same", 0, 0


def precedes(a: CallSite | BlockSite, b: CallSite | BlockSite) -> bool:
    """Whether ``a`` finishes before ``b`` starts (a sequence holds both, ``a`` first)."""
    kind, i, j = _relation(a.trail, b.trail)
    return kind == "sequence" and i < j


def _concurrent(a: tuple[Step, ...], b: tuple[Step, ...]) -> bool:
    return _relation(a, b)[0] == "parallel"


def walk(task: TaskFile) -> list[CallSite]:
    """Every call in document order (the task must have ids: :func:`assign_ids`)."""
    sites = [s for s in blocks(task) if isinstance(s.block, Call)]
    out = []
    for site in sites:
        assert isinstance(site.block, Call)
        others = tuple(o.path for o in sites if _concurrent(site.trail, o.trail))
        out.append(CallSite(site.path, site.block, site.trail, site.order, others))
    return out


# --------------------------------------------------------------------------- loading

_FIELDS = {
    "call": frozenset(f.name for f in msgspec.structs.fields(Call)) | {"block"},
    "sequence": frozenset(f.name for f in msgspec.structs.fields(Sequence)) | {"block"},
    "parallel": frozenset(f.name for f in msgspec.structs.fields(Parallel)) | {"block"},
}
_TOP = "'name' and a [root] block"
_PATH = re.compile(r"`(\$[^`]*)`")
_TOKEN = re.compile(r"\.([A-Za-z0-9_-]+)|\[(\d+)\]")
_HEADER = re.compile(r"^\s*(\[\[?)\s*([A-Za-z0-9_.\-\s\"']+?)\s*\]\]?\s*(#.*)?$")
_KEY = re.compile(r"^\s*([A-Za-z0-9_\-\"']+(?:\s*\.\s*[A-Za-z0-9_\-\"']+)*)\s*=")


def _keys(text: str) -> list[str]:
    return [k.strip().strip("\"'") for k in text.split(".")]


def _line_index(text: str) -> dict[tuple[str | int, ...], int]:
    """Best effort: concrete TOML paths (keys and array-of-tables indices) -> 1-based line.
    Inline tables are not looked into (their key's line stands for them)."""
    lines: dict[tuple[str | int, ...], int] = {}
    counts: dict[tuple[str | int, ...], int] = {}
    table: tuple[str | int, ...] = ()
    concrete: tuple[str | int, ...]
    for number, line in enumerate(text.splitlines(), 1):
        header = _HEADER.match(line)
        if header:
            keys, concrete = _keys(header.group(2)), ()
            for i, key in enumerate(keys):
                concrete = (*concrete, key)
                if concrete in counts and i < len(keys) - 1:  # the array's last table
                    concrete = (*concrete, counts[concrete] - 1)
            if header.group(1) == "[[":
                counts[concrete] = counts.get(concrete, 0) + 1
                concrete = (*concrete, counts[concrete] - 1)
            table = concrete
            lines.setdefault(table, number)
            continue
        assignment = _KEY.match(line)
        if assignment:
            lines.setdefault((*table, *_keys(assignment.group(1))), number)
    return lines


def _located(
    message: str, tokens: tuple[str | int, ...], text: str, source: str
) -> VerificationError:
    index = _line_index(text)
    line = next((index[tokens[:n]] for n in range(len(tokens), 0, -1) if tokens[:n] in index), 0)
    indices = [t for t in tokens if isinstance(t, int)]
    block = ""
    if tokens[:1] == (ROOT_PATH,):
        block = f" (block {'.'.join([ROOT_PATH, *map(str, indices)])})"
    head = f"{source}:{line}" if line else source
    return VerificationError(f"{head}: {message}{block}")


def _tokens(path: str) -> tuple[str | int, ...]:
    return tuple(int(i) if i else k for k, i in _TOKEN.findall(path))


def _unknown_keys(
    raw: Any, path: tuple[str | int, ...]
) -> Iterator[tuple[str, tuple[str | int, ...]]]:
    if not isinstance(raw, dict):
        return
    allowed = _FIELDS.get(str(raw.get("block")), frozenset())
    for key in sorted(set(raw) - allowed):
        hint = did_you_mean(key, allowed)
        yield f"unknown field `{key}` in a {raw.get('block')} block{hint}", (*path, key)
    children = raw.get("children")
    if isinstance(children, list):
        for i, child in enumerate(children):
            yield from _unknown_keys(child, (*path, "children", i))


def load_task_file(text: str, *, source: str = "<text>") -> TaskFile:
    """The task in ``text`` (TOML), every block with an id (:func:`assign_ids`).

    Raises :class:`~task_agent.VerificationError` naming ``source``, the line when it
    can be found, msgspec's path and the block for a malformed file."""
    try:
        raw = tomllib.loads(text)
    except tomllib.TOMLDecodeError as exc:
        raise VerificationError(f"{source}: invalid TOML: {exc}") from None
    try:
        task = msgspec.toml.decode(text, type=TaskFile)
    except msgspec.ValidationError as exc:
        message, found = str(exc), _PATH.search(str(exc))
        tokens = _tokens(found.group(1)) if found else ()
        if not found and (field := re.search(r"unknown field `([^`]+)`", message)):
            tokens = (field.group(1),)
            hint = did_you_mean(field.group(1), ("name", ROOT_PATH))
            message = f"unknown top-level field `{field.group(1)}`{hint} A task file has {_TOP}"
        elif tokens[-1:] == ("block",) and message.startswith("Invalid value"):
            message += "; a block is 'call', 'sequence' or 'parallel'"
        raise _located(message, tokens, text, source) from None
    for message, tokens in _unknown_keys(raw.get(ROOT_PATH), (ROOT_PATH,)):
        raise _located(message, tokens, text, source)
    return assign_ids(task)


def read_task_file(path: str | Path) -> TaskFile:
    """:func:`load_task_file` on the file at ``path`` (its name is the ``source``)."""
    try:
        text = Path(path).read_text(encoding="utf-8")
    except (OSError, UnicodeDecodeError) as exc:
        raise VerificationError(f"cannot read task file {path}: {exc}") from None
    return load_task_file(text, source=str(path))
