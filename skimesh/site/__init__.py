"""Running a site: ``skimesh up SITE.toml`` brings up one host's processes in dependency
order with health checks, restarts them by a policy, logs each one, and stops them cleanly.

The site file's schema (:class:`Site` and its tables; every key in docs/reference/site.md)
is read by :func:`load_site`; :func:`make_plan` checks it and plans it for one host
(:class:`Plan`: every :class:`Component` with its command line and readiness probe, in start
order); :class:`Supervisor` runs a plan; :class:`StateDir` is a host's state directory (lock,
status file, logs). Errors: :class:`SiteError`.
"""

from ._plan import Component, Plan, SiteError, load_site, make_plan, pick_host
from ._probe import probe
from ._restart import describe_exit, restart_delay
from ._schema import Agents, Host, Monitor, Restart, Router, Sim, Site, Store, TaskAgent
from ._state import Row, StateDir, Status, default_state_dir
from ._supervisor import Supervisor
from ._view import LineView, LiveView, row_line, table

__all__ = [
    "Agents",
    "Component",
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
    "StateDir",
    "Status",
    "Store",
    "Supervisor",
    "TaskAgent",
    "default_state_dir",
    "describe_exit",
    "load_site",
    "make_plan",
    "pick_host",
    "probe",
    "restart_delay",
    "row_line",
    "table",
]
