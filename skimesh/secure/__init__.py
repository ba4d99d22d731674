"""A site that is secure by default off loopback: its certificate authority, one credential
per component, and a least-privilege access-control list.

:class:`SiteSecurity` makes (or reuses) them in one folder: the site CA and certificates
(:class:`CertificateAuthority`, :class:`CertFiles`, with ``cryptography``), the router's Zenoh
config (TLS only, mutual TLS, the ACL of :func:`acl` matching each component by its
certificate's common name) and each component's client config. :class:`Component` names a
process and its :data:`Role`. The loopback demo needs none of it.

Modules: ``_pki`` (CA and certificates), ``_policy`` (the ACL), ``_site`` (the files),
``_errors``.
"""

from ._errors import SecureError as SecureError
from ._pki import CertFiles as CertFiles
from ._pki import CertificateAuthority as CertificateAuthority
from ._policy import ROLES as ROLES
from ._policy import Component as Component
from ._policy import Role as Role
from ._policy import acl as acl
from ._site import ROUTER as ROUTER
from ._site import SiteSecurity as SiteSecurity

__all__ = [
    "ROLES",
    "ROUTER",
    "CertFiles",
    "CertificateAuthority",
    "Component",
    "Role",
    "SecureError",
    "SiteSecurity",
    "acl",
]
