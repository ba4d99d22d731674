"""Site credentials and policy without a mesh: the CA is made once and reused, certificates
are renewed only when due or when the router gains a host, keys are private, the ACL gives
each component its role's rules and nothing else, and bad input is refused with a reason."""

from __future__ import annotations

import json
import stat
from pathlib import Path

import pytest
from cryptography import x509

from skimesh.secure import ROUTER, Component, SecureError, SiteSecurity, acl

COMPONENTS = [
    Component("wm", "wm"),
    Component("host-a", "agent", {"r1-arm": "r1", "r1-base": "r1"}),
    Component("viewer", "viewer"),
]


def cert(path: Path) -> x509.Certificate:
    return x509.load_pem_x509_certificate(path.read_bytes())


def test_credentials_are_made_once_and_reused(tmp_path: Path) -> None:
    site = SiteSecurity(tmp_path / "site", COMPONENTS, hosts=["router.example", "10.0.0.5"])
    site.ensure()
    ca, router = cert(tmp_path / "site/ca.pem"), cert(tmp_path / "site/router.pem")
    assert router.issuer == ca.subject
    names = router.extensions.get_extension_for_class(x509.SubjectAlternativeName).value
    assert {str(n.value) for n in names} == {"router.example", "10.0.0.5"}
    agent = cert(tmp_path / "site/host-a.pem")
    assert agent.subject.get_attributes_for_oid(x509.NameOID.COMMON_NAME)[0].value == "host-a"
    for key in (tmp_path / "site").glob("*-key.pem"):
        assert stat.S_IMODE(key.stat().st_mode) == 0o600, key
    site.ensure()  # again: nothing new
    assert cert(tmp_path / "site/ca.pem").serial_number == ca.serial_number
    assert cert(tmp_path / "site/host-a.pem").serial_number == agent.serial_number
    grown = SiteSecurity(tmp_path / "site", COMPONENTS, hosts=["router.example", "10.0.0.6"])
    grown.ensure()  # a new host: a new router certificate, the same CA
    assert cert(tmp_path / "site/router.pem").serial_number != router.serial_number
    assert cert(tmp_path / "site/ca.pem").serial_number == ca.serial_number


def test_the_acl_gives_each_component_only_its_roles_rules() -> None:
    policy = acl(COMPONENTS)
    assert policy["default_permission"] == "deny"
    rules = {r["id"]: r for r in policy["rules"]}
    by_subject = {p["subjects"][0]: p["rules"] for p in policy["policies"] if p["id"] != "everyone"}
    assert "viewer" not in by_subject, "the viewer has nothing beyond everyone's reads"
    agent_keys = [k for rule in by_subject["host-a"] for k in rules[rule]["key_exprs"]]
    assert "skimesh/*/wm/write/r1-arm" in agent_keys and "skimesh/*/wm/write/r1-base" in agent_keys
    assert "skimesh/*/devices/r1/*/cmd" in agent_keys
    assert not any("wm/rpc" in k or "devices/**" in k for k in agent_keys)
    assert {s["id"]: s["cert_common_names"] for s in policy["subjects"]}["host-a"] == ["host-a"]


def test_the_router_config_is_tls_only_with_mutual_tls(tmp_path: Path) -> None:
    site = SiteSecurity(tmp_path, COMPONENTS, hosts=["localhost"])
    site.ensure()
    config = json.loads(site.router_config(["tls/0.0.0.0:7447"]).read_text())
    tls = config["transport"]["link"]["tls"]
    assert config["transport"]["link"]["protocols"] == ["tls"] and tls["enable_mtls"] is True
    assert ROUTER in [s["id"] for s in config["access_control"]["subjects"]]
    client = json.loads(site.client_config("wm", ["tls/localhost:7447"]).read_text())
    assert client["transport"]["link"]["tls"]["connect_certificate"].endswith("wm.pem")
    with pytest.raises(SecureError, match="tls/HOST:PORT"):
        site.router_config(["tcp/0.0.0.0:7447"])
    with pytest.raises(SecureError, match="no component 'nobody'"):
        site.client_config("nobody", ["tls/localhost:7447"])


@pytest.mark.parametrize(
    ("components", "message"),
    [
        ([Component("a", "wm"), Component("a", "viewer")], "a given twice"),
        (
            [Component("a", "agent", {"r1": "r1"}), Component("b", "agent", {"r1": "r1"})],
            "agent r1 is served by two components",
        ),
    ],
)
def test_bad_sites_are_refused_with_the_reason(components: list[Component], message: str) -> None:
    with pytest.raises(SecureError, match=message):
        acl(components)


def test_bad_components_are_refused_with_the_reason() -> None:
    with pytest.raises(SecureError, match="serves no agent"):
        Component("a", "agent")
    with pytest.raises(SecureError, match="unknown role"):
        Component("a", "root")  # type: ignore[arg-type]
    with pytest.raises(SecureError, match="component name"):
        Component("a/b", "viewer")
    with pytest.raises(SecureError, match="routers' own name"):
        SiteSecurity(Path("/nonexistent"), [Component(ROUTER, "viewer")], hosts=["h"])
