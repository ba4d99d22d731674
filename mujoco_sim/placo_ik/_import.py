"""The one place that imports placo (untyped: every placo object is ``Any``).

Importing placo imports pinocchio, which imports ``hppfcl``, a shim that warns
``DeprecationWarning: Please update your 'hppfcl' imports to 'coal'`` on import. That warning is
about pinocchio's own import, not ours; it is silenced here, for that message only, so that test
suites that turn warnings into errors can import placo.
"""

from __future__ import annotations

import warnings

with warnings.catch_warnings():
    warnings.filterwarnings(
        "ignore", message="Please update your 'hppfcl' imports", category=DeprecationWarning
    )
    import placo

__all__ = ["placo"]
