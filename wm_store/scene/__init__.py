"""The scene graph: elements and relations with their indexes, the queries over them, and the
transactions that change them. Pure and synchronous; shared by the store (its authoritative
state) and the client (its replica), so both index and answer the same way.

- :class:`SceneState`: elements, relations and native indexes (type, label, relations in both
  directions, spatial parent, sorted numeric properties); applies deltas, validates nothing.
- :func:`resolve`, :func:`match_relations`, :func:`id_sort_key`: read queries.
- :func:`apply_transaction`: validate ops against the ontology and apply them all, or none,
  every name naming one element (``_names``: ids vs labels, unique labels, assigned ids that
  avoid labels; its ``display_name`` is public as :func:`wm_store.display_name`).
- :func:`merge_observation` / :func:`resolve_observations`: multi-source property resolution.
- :func:`min_cardinality_violations`: the minimum-cardinality report (``CheckCardinality``).
- :func:`ownership` / :func:`check_writer`: what each agent registered, and the store's refusal
  of an agent's write to another agent's elements (:class:`Ownership`, :data:`STRUCTURE`).

Transactions (``_transactions``, which read Turtle with rdflib) load on first use (PEP 562).
"""

from __future__ import annotations

from typing import TYPE_CHECKING

from wm_store._lazy import lazy_getattr

from ._cardinality import min_cardinality_violations as min_cardinality_violations
from ._ownership import STRUCTURE as STRUCTURE
from ._ownership import Ownership as Ownership
from ._ownership import changes_ownership as changes_ownership
from ._ownership import check_writer as check_writer
from ._ownership import ownership as ownership
from ._query import id_sort_key as id_sort_key
from ._query import match_relations as match_relations
from ._query import resolve as resolve
from ._resolution import ResolutionPolicy as ResolutionPolicy
from ._resolution import merge_observation as merge_observation
from ._resolution import resolve_observations as resolve_observations
from ._state import SceneState as SceneState
from ._state import Undo as Undo
from ._state import parse_id as parse_id

if TYPE_CHECKING:
    from ._transactions import SELF as SELF
    from ._transactions import TxnResult as TxnResult
    from ._transactions import apply_transaction as apply_transaction

__getattr__ = lazy_getattr(  # the names imported on first use (PEP 562), and their modules
    __name__,
    {
        "SELF": "._transactions",
        "TxnResult": "._transactions",
        "apply_transaction": "._transactions",
    },
)


__all__ = [
    "SELF",
    "STRUCTURE",
    "Ownership",
    "ResolutionPolicy",
    "SceneState",
    "TxnResult",
    "Undo",
    "apply_transaction",
    "changes_ownership",
    "check_writer",
    "id_sort_key",
    "match_relations",
    "merge_observation",
    "min_cardinality_violations",
    "ownership",
    "parse_id",
    "resolve",
    "resolve_observations",
]
