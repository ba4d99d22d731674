"""Names the scene would clash with: a scenario label that is already the id of an element of
the world model (one an agent registered before the scene was loaded: its robot's camera got
the id ``Camera-1`` while the scenario labels its overhead camera ``Camera-1``). The store
refuses such a label (a name names one element); :func:`name_clashes` says so first, with
the way out.
"""

from __future__ import annotations

from collections.abc import Sequence

from wm_store import display_name
from wm_store.protocol import AddElement, Op
from wm_store.scene import SceneState

__all__ = ["name_clashes"]


def name_clashes(ops: Sequence[Op], state: SceneState) -> list[str]:
    """For each element ``ops`` add whose label is already another element's id in ``state``:
    what clashes, and what to do."""
    return [
        f"the scene's label {op.label!r} is already the id of "
        f"{display_name(state.elements[op.label])}, which was there first (an agent registered "
        "it before the scene was loaded); a name names one element: load the scene before "
        "starting the agents, or give the scenario's element another label"
        for op in ops
        if isinstance(op, AddElement) and op.label and op.label in state
    ]
