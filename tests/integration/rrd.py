"""Reading a finished rerun recording in tests: its chunks and the values of one column."""

from __future__ import annotations

from pathlib import Path

import rerun

__all__ = ["chunks", "column"]


def chunks(path: Path) -> list[rerun.chunk.Chunk]:
    """Every chunk of the first recording in the ``.rrd`` file ``path``."""
    reader = rerun.chunk.RrdReader(str(path))
    return list(reader.stream(store=reader.recordings()[0]).to_chunks())


def column(chunk: rerun.chunk.Chunk, name: str) -> list[object]:
    """The values of column ``name`` of ``chunk``, flattened ([] if it has none)."""
    batch = chunk.to_record_batch()
    if name not in batch.schema.names:
        return []
    return [v for cell in batch.column(name).to_pylist() for v in cell or []]
