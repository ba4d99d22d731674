"""Durability of the store: a write-ahead log with group commit, plus snapshots.

- :class:`Durability`: durable commits (group commit by one writer task, fsync in a worker
  thread), snapshot writing and log compaction, recovery; fail-stop on a write or fsync error.
- :class:`WriteAheadLog`: the append-only log of ``(seq, payload)`` records in CRC-checked
  segment files; blocking I/O, called from a worker thread.
- :class:`SnapshotFiles`: whole-state snapshots written atomically, the newest ``keep`` kept.
"""

from ._durability import Durability as Durability
from ._durability import DurabilityMode as DurabilityMode
from ._durability import DurabilityStats as DurabilityStats
from ._durability import Recovered as Recovered
from ._snapshots import SNAPSHOT_MAGIC as SNAPSHOT_MAGIC
from ._snapshots import SnapshotFiles as SnapshotFiles
from ._wal import DEFAULT_MAX_RECORD_BYTES as DEFAULT_MAX_RECORD_BYTES
from ._wal import DEFAULT_SEGMENT_BYTES as DEFAULT_SEGMENT_BYTES
from ._wal import RecoveryReport as RecoveryReport
from ._wal import WalStats as WalStats
from ._wal import WriteAheadLog as WriteAheadLog

__all__ = [
    "DEFAULT_MAX_RECORD_BYTES",
    "DEFAULT_SEGMENT_BYTES",
    "SNAPSHOT_MAGIC",
    "Durability",
    "DurabilityMode",
    "DurabilityStats",
    "Recovered",
    "RecoveryReport",
    "SnapshotFiles",
    "WalStats",
    "WriteAheadLog",
]
