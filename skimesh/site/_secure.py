"""A site secure by default off loopback: which components need which credential, and making
them (:func:`security_of`, :func:`ensure_credentials`).

A site whose routers listen beyond loopback (``security = "auto"``, the default) or that asks
for it (``"tls"``) runs on TLS only, with mutual TLS and the least-privilege ACL of
:mod:`skimesh.secure`: every process logs in with its own certificate (its component's name),
the routers' certificate names every host's address, and ``operator`` is the credential of
the site's people (``skimesh task submit --config <credentials>/operator.json5``) and of
``skimesh up``'s own health checks. The loopback demo and a one-host site on 127.0.0.1 stay
zero-config. ``security = "none"`` keeps an open mesh (a trusted, isolated network).

The credentials live in one folder (``credentials`` in the site file; default
``<site file name>-credentials`` beside it): made by the first ``skimesh up`` that finds it
missing, reused afterwards. On several hosts, make them once (``skimesh up`` on any host) and
copy the folder to the others (``ca-key.pem`` only where new certificates are made).
"""

from __future__ import annotations

import fcntl
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING

from ._endpoint import ANY_ADDRESS, parse_endpoint
from ._errors import SiteError
from ._schema import Site

if TYPE_CHECKING:
    from ._plan import Plan

__all__ = ["LOOPBACK", "OPERATOR", "SiteSecurityPlan", "ensure_credentials", "security_of", "tls"]

LOOPBACK = frozenset({"127.0.0.1", "localhost", "::1", "[::1]"})
OPERATOR = "operator"
"""The credential of the site's people and of ``skimesh up``'s health checks."""


@dataclass(frozen=True)
class SiteSecurityPlan:
    """Where a secure site's credentials are and what each process logs in with."""

    folder: Path
    hosts: tuple[str, ...]
    """Every name or address clients dial to reach a router (the routers' certificate)."""

    def client(self, component: str) -> str:
        return str(self.folder / f"{component}.json5")

    def router(self) -> str:
        return str(self.folder / "router.json5")


def security_of(site: Site, path: Path) -> SiteSecurityPlan | None:
    """The site's security plan, or None for an open mesh (see the module doc)."""
    listens = [parse_endpoint(e)[1] for r in site.routers for e in r.listen]
    beyond = any(a not in LOOPBACK for a in listens)
    if site.security == "none" or (site.security == "auto" and not beyond):
        return None
    folder = Path(site.credentials).expanduser() if site.credentials else None
    if folder is None:
        folder = path.parent / f"{path.stem}-credentials"
    elif not folder.is_absolute():
        folder = path.parent / folder
    hosts = {"localhost", "127.0.0.1"}
    hosts.update(h.address for h in site.hosts.values() if h.address)
    hosts.update(a.strip("[]") for a in listens if a not in ANY_ADDRESS)
    return SiteSecurityPlan(folder.resolve(), tuple(sorted(hosts)))


def tls(endpoint: str) -> str:
    """``endpoint`` on TLS (``tcp/H:P`` -> ``tls/H:P``)."""
    return "tls/" + endpoint.split("/", 1)[1] if endpoint.startswith("tcp/") else endpoint


_ROLES = {
    "store": "wm",
    "sim": "sim",
    "agents": "agent",
    "task-agent": "task-agent",
    "monitor": "viewer",
    "eventlog": "eventlog",
}


def ensure_credentials(plan: Plan) -> Path:
    """Make what a secure site's credentials folder lacks (the CA once, a certificate per
    component and for the routers, the Zenoh configs); returns the folder. Raises SiteError
    if they cannot be made."""
    from ..secure import SecureError

    security = plan.security
    assert security is not None
    try:
        security.folder.mkdir(parents=True, exist_ok=True)
        with open(security.folder / ".lock", "w") as lock:
            fcntl.flock(lock, fcntl.LOCK_EX)  # hosts starting together make one CA, not two
            _make(plan, security)
    except (SecureError, OSError) as e:
        raise SiteError(f"the site's credentials in {security.folder}: {e}") from e
    return security.folder


def _make(plan: Plan, security: SiteSecurityPlan) -> None:
    from ..secure import Component, SiteSecurity

    components = [
        Component(c.name, _ROLES[c.kind], dict(c.serves))  # type: ignore[arg-type]
        for c in plan.components
        if c.kind != "router"
    ]
    components.append(Component(OPERATOR, "operator"))
    site = SiteSecurity(security.folder, components, security.hosts, site=plan.site.mesh)
    site.ensure()
    first = plan.site.routers[0]
    site.router_config([tls(e) for e in first.listen], [tls(e) for e in first.connect])
    for c in components:
        site.client_config(c.name, list(plan.connect))
