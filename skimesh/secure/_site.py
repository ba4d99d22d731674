"""A secure site's files: :class:`SiteSecurity` makes (or reuses) them in one folder.

- ``ca.pem`` / ``ca-key.pem``: the site's certificate authority (keep the key on one host);
- ``router.pem`` / ``router-key.pem``: the routers' certificate, naming every host clients
  dial; routers link to each other with it (mTLS both ways);
- ``<component>.pem`` / ``<component>-key.pem``: one credential per component;
- ``router.json5``: the router's Zenoh config: TLS only, mTLS (a client without a certificate
  of the site CA cannot even open a session), the least-privilege ACL of :func:`~._policy.acl`;
- ``<component>.json5``: each component's client config (TLS, its certificate, the router's
  name verified).

The configs are JSON (valid JSON5), read by ``skimesh ... --config FILE`` like any other.
"""

from __future__ import annotations

import json
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from ._errors import SecureError
from ._pki import CertFiles, CertificateAuthority
from ._policy import Component, acl

__all__ = ["ROUTER", "SiteSecurity"]

ROUTER = "router"
"""The common name of the routers' certificate (and their subject in the ACL)."""
_LINK = {"tx": {"lease": 4000, "keep_alive": 4}}


def _tls_only(endpoints: Sequence[str], what: str) -> list[str]:
    bad = [e for e in endpoints if not e.startswith("tls/")]
    if bad:
        raise SecureError(f"a secure site's {what} endpoints are tls/HOST:PORT, not {bad}")
    return list(endpoints)


@dataclass
class SiteSecurity:
    """The credentials and policy of one site in ``folder`` (see the module doc).
    ``hosts``: every name or IP address clients and routers dial to reach a router."""

    folder: Path
    components: Sequence[Component]
    hosts: Sequence[str]
    site: str = "skimesh site"

    def __post_init__(self) -> None:
        if not self.hosts:
            raise SecureError("name the hosts (or IP addresses) clients dial to reach the router")
        if ROUTER in {c.name for c in self.components}:
            raise SecureError(f"{ROUTER!r} is the routers' own name: choose another component name")
        self._acl = acl(self.components)  # checks the components before anything is written

    def ensure(self) -> CertificateAuthority:
        """Make what is missing (the CA once, certificates when missing or due): see
        :meth:`~._pki.CertificateAuthority.issue`."""
        ca = CertificateAuthority(self.folder, site=self.site)
        ca.issue(ROUTER, hosts=self.hosts, client=True)
        for c in self.components:
            ca.issue(c.name)
        return ca

    def _files(self, name: str) -> CertFiles:
        return CertFiles(self.folder / f"{name}.pem", self.folder / f"{name}-key.pem")

    def router_config(self, listen: Sequence[str], connect: Sequence[str] = ()) -> Path:
        """Write ``router.json5``: listen on ``listen``, link to the routers ``connect``."""
        ca, mine = self.folder / "ca.pem", self._files(ROUTER)
        policy = dict(self._acl)
        policy["rules"] = [*policy["rules"], _ROUTERS_RULE]
        policy["subjects"] = [*policy["subjects"], {"id": ROUTER, "cert_common_names": [ROUTER]}]
        policy["policies"] = [
            *policy["policies"],
            {"id": "routers", "rules": ["routers"], "subjects": [ROUTER]},
        ]
        config: dict[str, Any] = {
            "mode": "router",
            "listen": {"endpoints": _tls_only(listen, "listen")},
            "connect": {"endpoints": _tls_only(connect, "connect")},
            "scouting": {"multicast": {"enabled": False}, "gossip": {"enabled": False}},
            "transport": {
                "link": {
                    "protocols": ["tls"],
                    **_LINK,
                    "tls": {
                        "root_ca_certificate": str(ca),
                        "listen_certificate": str(mine.cert),
                        "listen_private_key": str(mine.key),
                        "connect_certificate": str(mine.cert),
                        "connect_private_key": str(mine.key),
                        "enable_mtls": True,
                        "close_link_on_expiration": True,
                    },
                }
            },
            "adminspace": {"enabled": False},
            "access_control": policy,
        }
        return self._write("router.json5", config)

    def client_config(self, component: str, connect: Sequence[str]) -> Path:
        """Write ``<component>.json5``: a client of the routers ``connect`` logged in with
        the component's certificate."""
        if component not in {c.name for c in self.components}:
            raise SecureError(f"no component {component!r} in this site")
        mine = self._files(component)
        config = {
            "mode": "client",
            "connect": {"endpoints": _tls_only(connect, "connect")},
            "listen": {"endpoints": []},
            "scouting": {"multicast": {"enabled": False}, "gossip": {"enabled": False}},
            "transport": {
                "link": {
                    "protocols": ["tls"],
                    **_LINK,
                    "tls": {
                        "root_ca_certificate": str(self.folder / "ca.pem"),
                        "connect_certificate": str(mine.cert),
                        "connect_private_key": str(mine.key),
                        "enable_mtls": True,
                        "verify_name_on_connect": True,
                    },
                }
            },
        }
        return self._write(f"{component}.json5", config)

    def _write(self, name: str, config: dict[str, Any]) -> Path:
        path = self.folder / name
        path.write_text(json.dumps(config, indent=2) + "\n", encoding="utf-8")
        return path


_ROUTERS_RULE = {
    # Routers pass on what their own clients were allowed to send (each router enforces its
    # clients' rules), so a linked router's messages are allowed here.
    "id": "routers",
    "messages": [
        "put", "delete", "declare_subscriber", "query", "reply", "declare_queryable",
        "liveliness_token", "liveliness_query", "declare_liveliness_subscriber",
    ],
    "flows": ["ingress"],
    "permission": "allow",
    "key_exprs": ["skimesh/**", "@meshlink/**"],
}  # fmt: skip
