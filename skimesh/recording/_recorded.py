"""The layout a recording was sent with, read back: its views and its 3-D camera.

``skimesh demo`` and ``skimesh sim`` send their default layout (:func:`blueprint`) into the
``.rrd``, as a blueprint store beside the recording. :func:`recorded_views` lists its views
(what a test checks, what ``python -m skimesh.recording`` prints) and :func:`recorded_eye`
its camera (which ``scripts/screenshot`` reuses: the viewer cannot be handed that store with
a cut copy of the recording).
"""

from __future__ import annotations

from typing import Any

from ._framing import Eye

__all__ = ["recorded_eye", "recorded_views"]


def _blueprint_rows(reader: Any) -> list[tuple[str, Any]]:
    """(entity path, record batch) of every chunk of the layouts (blueprint stores)."""
    return [
        (str(chunk.entity_path), chunk.to_record_batch())
        for store in reader.blueprints()
        for chunk in reader.stream(store=store).to_chunks()
    ]


def _first(cell: Any) -> Any:
    return cell[0] if isinstance(cell, list) and cell else cell


def recorded_views(reader: Any) -> dict[str, tuple[str, str]]:
    """The views of the layouts in what ``reader`` (an ``RrdReader`` of an ``.rrd`` or
    ``.rbl``) reads: each view's name -> (its kind: ``3D``, ``TextLog``, ``Graph``, ...; its
    origin, ``/``-prefixed)."""
    views: dict[str, tuple[str, str]] = {}
    columns = ("class_identifier", "display_name", "space_origin")
    for _, batch in _blueprint_rows(reader):
        names = batch.schema.names
        if not all(f"ViewBlueprint:{c}" in names for c in columns):
            continue
        rows = zip(*(batch.column(f"ViewBlueprint:{c}").to_pylist() for c in columns), strict=True)
        for kind, name, origin in rows:
            if kind and name:
                views[str(_first(name))] = (
                    str(_first(kind)),
                    "/" + str(_first(origin)).lstrip("/"),
                )
    return views


def recorded_eye(reader: Any) -> Eye | None:
    """The 3-D camera (``EyeControls3D``) of the last layout sent with the recording that
    ``reader`` (an ``RrdReader``) reads, or None."""
    eye: Eye | None = None
    for entity, batch in _blueprint_rows(reader):
        names = batch.schema.names
        if not entity.endswith("/EyeControls3D") or not {
            "EyeControls3D:position",
            "EyeControls3D:look_target",
        } <= set(names):
            continue
        positions = batch.column("EyeControls3D:position").to_pylist()
        targets = batch.column("EyeControls3D:look_target").to_pylist()
        for position, target in zip(positions, targets, strict=True):
            if position and target:
                p, t = (tuple(float(v) for v in x[0]) for x in (position, target))
                eye = Eye(position=(p[0], p[1], p[2]), look_target=(t[0], t[1], t[2]))
    return eye
