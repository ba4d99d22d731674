"""The site event log: every event of the mesh in one durable, queryable place.

FRIEND II kept every event of its reactive layer in an event logging server, so the course of
actions could be analysed offline. Here ``skimesh eventlog`` (:func:`serve_event_log`) is that
server: one process anywhere on the mesh follows every task's events, every skill agent's event
log and liveliness, every device's state changes and every world-model change
(:class:`EventRecorder`, :class:`Translator`), keeps them as flat :class:`EventRecord` rows in
one SQLite file (:class:`EventStore`) and answers filtered queries on ``eventlog/rpc``
(:class:`QueryEvents`, :class:`EventFilter`; :class:`EventLogClient`). ``skimesh events``
filters by time, robot, task, skill, kind and outcome, follows, and exports JSON lines or
Parquet (:func:`write_jsonl`, :func:`write_parquet`).

Modules: ``_records`` (records, filter, wire), ``_store`` (SQLite), ``_translate``,
``_recorder``, ``_service``, ``_client``, ``_export``, ``_errors``.
"""

from ._client import EventLogClient as EventLogClient
from ._errors import EventLogError as EventLogError
from ._export import FORMATS as FORMATS
from ._export import export_format as export_format
from ._export import write_jsonl as write_jsonl
from ._export import write_parquet as write_parquet
from ._recorder import EventRecorder as EventRecorder
from ._records import KINDS as KINDS
from ._records import EventFilter as EventFilter
from ._records import EventKind as EventKind
from ._records import EventRecord as EventRecord
from ._records import EventsReply as EventsReply
from ._records import LogInfo as LogInfo
from ._records import LogInfoReply as LogInfoReply
from ._records import QueryEvents as QueryEvents
from ._service import EventLogService as EventLogService
from ._service import serve_event_log as serve_event_log
from ._store import EventStore as EventStore
from ._translate import Translator as Translator

__all__ = [
    "FORMATS",
    "KINDS",
    "EventFilter",
    "EventKind",
    "EventLogClient",
    "EventLogError",
    "EventLogService",
    "EventRecord",
    "EventRecorder",
    "EventStore",
    "EventsReply",
    "LogInfo",
    "LogInfoReply",
    "QueryEvents",
    "Translator",
    "export_format",
    "serve_event_log",
    "write_jsonl",
    "write_parquet",
]
