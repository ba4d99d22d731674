"""Writing records for offline analysis: JSON lines (:func:`write_jsonl`) or Parquet
(:func:`write_parquet`, through pyarrow, which rerun-sdk already brings; imported only here)."""

from __future__ import annotations

from collections.abc import Iterable
from pathlib import Path
from typing import IO

import msgspec

from ._errors import EventLogError
from ._records import EventRecord

__all__ = ["FORMATS", "export_format", "write_jsonl", "write_parquet"]

FORMATS = ("jsonl", "parquet")
_encoder = msgspec.json.Encoder()


def export_format(path: str) -> str:
    """The format a file name asks for (``.parquet`` or JSON lines for anything else)."""
    return "parquet" if path.lower().endswith(".parquet") else "jsonl"


def write_jsonl(records: Iterable[EventRecord], out: IO[bytes]) -> int:
    """One JSON object per line (the record's fields; ``data`` stays a JSON text). Returns
    the number written."""
    count = 0
    for record in records:
        out.write(_encoder.encode(record) + b"\n")
        count += 1
    return count


def write_parquet(records: list[EventRecord], path: str | Path) -> int:
    """One Parquet file, one column per field. Returns the number written."""
    try:
        import pyarrow as pa  # type: ignore[import-untyped]
        import pyarrow.parquet as pq  # type: ignore[import-untyped]
    except ImportError as e:  # pragma: no cover - pyarrow comes with rerun-sdk
        raise EventLogError(f"Parquet export needs pyarrow ({e}); use JSON lines") from None
    fields = list(EventRecord.__struct_fields__)
    table = pa.table({f: [getattr(r, f) for r in records] for f in fields})
    pq.write_table(table, str(path))
    return len(records)
