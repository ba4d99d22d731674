"""Running a site: ``skimesh up SITE.toml`` brings up one host's processes in dependency
order with health checks, restarts them by a policy, logs each one, and stops them cleanly.

The site file's schema (:class:`Site` and its tables; every key in docs/reference/site.md)
is read by :func:`load_site`; :func:`make_plan` checks it and plans it for one host
(:class:`Plan`: every :class:`Component` with its command line and readiness probe, in start
order); :class:`Supervisor` runs a plan; :class:`StateDir` is a host's state directory (lock,
status file, logs). A site that listens beyond loopback is secure by default
(:func:`security_of`, :func:`ensure_credentials`: TLS, a certificate per component and a
least-privilege ACL, from :mod:`skimesh.secure`). Errors: :class:`SiteError`.
"""

from ._errors import SiteError
from ._plan import Component, Plan, load_site, make_plan, pick_host
from ._probe import probe
from ._restart import describe_exit, restart_delay
from ._schema import (
    Agents,
    EventLog,
    Host,
    Monitor,
    Restart,
    Router,
    Sim,
    Site,
    Store,
    TaskAgent,
)
from ._secure import OPERATOR, SiteSecurityPlan, ensure_credentials, security_of
from ._state import Row, StateDir, Status, default_state_dir
from ._supervisor import Supervisor
from ._view import LineView, LiveView, row_line, table

__all__ = [
    "OPERATOR",
    "Agents",
    "Component",
    "EventLog",
    "Host",
    "LineView",
    "LiveView",
    "Monitor",
    "Plan",
    "Restart",
    "Router",
    "Row",
    "Sim",
    "Site",
    "SiteError",
    "SiteSecurityPlan",
    "StateDir",
    "Status",
    "Store",
    "Supervisor",
    "TaskAgent",
    "default_state_dir",
    "describe_exit",
    "ensure_credentials",
    "load_site",
    "make_plan",
    "pick_host",
    "probe",
    "restart_delay",
    "row_line",
    "security_of",
    "table",
]
