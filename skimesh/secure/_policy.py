"""The least-privilege access-control list of a site, made from its components.

Each component (a process, or a process serving several agents) logs in with its own
certificate, whose common name is the component's name; the router matches it
(``cert_common_names``) to the rules of its role. The policy is deny by default and follows the
shipped ``configs/zenoh/router-acl.json5`` (its README explains each rule), with each robot's
rules made for the robots the site names:

========== ==================================================================================
role       may, beside what everyone may read
========== ==================================================================================
wm         serve ``wm/rpc``, ``wm/write/*``, ``wm/query``, ``wm/elements/**``; publish changes
sim        serve every device and ``sim/truth``; publish device states and progress
drivers    the same for its own robots' devices only (real hardware)
agent      for each agent it serves: its liveliness token and keys ``agents/<agent>/**``, its
           robot's device commands, world-model writes as itself (``wm/write/<agent>``)
task-agent serve ``tasks/rpc``, task events, the operator agent and desk; write the world
           model; command agents
operator   write the world model; command agents, tasks and the operator desk
eventlog   serve ``eventlog/rpc``
viewer     nothing more: read-only (also the monitor)
========== ==================================================================================

Everyone may: subscribe to world-model changes, run progress, agents' event logs, task events,
device states and progress; watch agents' liveliness; query ``wm/query``, ``wm/elements/**``,
``agents/*/skills``, ``eventlog/rpc``, ``sim/truth``, ``tasks/query`` (task status, list and
history; submitting and aborting stay on ``tasks/rpc``).
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from typing import Any, Literal, get_args

from meshlink import InvalidKeyError, check_name

from ._errors import SecureError

__all__ = ["ROLES", "Component", "Role", "acl"]

Role = Literal["wm", "sim", "drivers", "agent", "task-agent", "operator", "eventlog", "viewer"]
ROLES: tuple[str, ...] = get_args(Role)

_READ = [
    "skimesh/*/wm/changes",
    "skimesh/*/agents/*/runs/*/progress",
    "skimesh/*/agents/*/events",
    "skimesh/*/tasks/*/events",
    "skimesh/*/devices/*/*/state",
    "skimesh/*/devices/*/*/progress/*",
]
_READ_QUERIES = [
    "@meshlink/sync",
    "skimesh/*/wm/query",
    "skimesh/*/wm/elements/**",
    "skimesh/*/agents/*/skills",
    "skimesh/*/eventlog/rpc",
    "skimesh/*/sim/truth",
    "skimesh/*/tasks/query",
]
_SERVE = ["declare_queryable", "reply", "put"]
_WATCH = ["declare_liveliness_subscriber", "liveliness_query"]


@dataclass(frozen=True)
class Component:
    """One process of the site: its ``name`` (its certificate's common name), its ``role``
    and, for the roles ``agent`` and ``drivers``, the agents it serves -> their robot's label
    (``{"r1": "r1"}``; split robot: ``{"r1-arm": "r1", "r1-base": "r1"}``)."""

    name: str
    role: Role
    agents: Mapping[str, str] = field(default_factory=dict)

    def __post_init__(self) -> None:
        try:
            check_name(self.name, "component name")
            for agent, robot in self.agents.items():
                check_name(agent, "agent name")
                check_name(robot, "robot name")
        except InvalidKeyError as e:
            raise SecureError(str(e)) from None
        if self.role not in ROLES:
            raise SecureError(f"component {self.name}: unknown role {self.role!r}; one of {ROLES}")
        if self.role in ("agent", "drivers") and not self.agents:
            raise SecureError(f"component {self.name} ({self.role}) serves no agent or robot")


def _rule(rule_id: str, messages: Sequence[str], keys: Sequence[str]) -> dict[str, Any]:
    return {
        "id": rule_id,
        "messages": list(messages),
        "flows": ["ingress"],
        "permission": "allow",
        "key_exprs": sorted(set(keys)),
    }


def _own_rules(c: Component) -> list[dict[str, Any]]:
    """The rules of ``c``'s role (beyond what everyone may)."""
    robots = sorted(set(c.agents.values()))
    match c.role:
        case "wm":
            keys = ["wm/rpc", "wm/write/*", "wm/query", "wm/elements/**", "wm/changes"]
            return [_rule(f"{c.name}:serve", _SERVE, [f"skimesh/*/{k}" for k in keys])]
        case "sim":
            return [
                _rule(f"{c.name}:serve", _SERVE, ["skimesh/*/devices/**", "skimesh/*/sim/truth"])
            ]
        case "drivers":
            keys = [f"skimesh/*/devices/{r}/**" for r in robots]
            return [_rule(f"{c.name}:serve", _SERVE, keys)]
        case "agent":
            own = [
                k for a in c.agents for k in (f"skimesh/*/agents/{a}", f"skimesh/*/agents/{a}/**")
            ]
            queries = [f"skimesh/*/devices/{r}/*/cmd" for r in robots]
            queries += [f"skimesh/*/wm/write/{a}" for a in c.agents]
            return [
                _rule(f"{c.name}:serve", ["liveliness_token", *_SERVE], own),
                _rule(f"{c.name}:query", ["query"], queries),
            ]
        case "task-agent":
            serve = [
                "skimesh/*/tasks/rpc",
                "skimesh/*/tasks/query",
                "skimesh/*/tasks/*/events",
                "skimesh/*/agents/operator",
                "skimesh/*/agents/operator/**",
                "skimesh/*/operator/rpc",
            ]
            return [
                _rule(f"{c.name}:serve", ["liveliness_token", *_SERVE], serve),
                _rule(f"{c.name}:query", ["query"], [*_WRITE, *_COMMAND]),
            ]
        case "operator":
            return [_rule(f"{c.name}:query", ["query"], [*_WRITE, *_COMMAND])]
        case "eventlog":
            return [
                _rule(f"{c.name}:serve", ["declare_queryable", "reply"], ["skimesh/*/eventlog/rpc"])
            ]
    return []  # viewer


_WRITE = ["skimesh/*/wm/rpc", "skimesh/*/wm/write/*"]
_COMMAND = ["skimesh/*/agents/*/rpc", "skimesh/*/tasks/rpc", "skimesh/*/operator/rpc"]


def acl(components: Sequence[Component]) -> dict[str, Any]:
    """The ``access_control`` section of the router's config for ``components``.

    Raises:
        SecureError: two components share a name, or two serve one agent.
    """
    names = [c.name for c in components]
    twice = sorted({n for n in names if names.count(n) > 1})
    if twice:
        raise SecureError(f"component names must be unique: {', '.join(twice)} given twice")
    served = [a for c in components if c.role == "agent" for a in c.agents]
    twice = sorted({a for a in served if served.count(a) > 1})
    if twice:
        raise SecureError(f"agent {', '.join(twice)} is served by two components")
    everyone = [
        {
            "id": "deliver",
            "messages": [
                "put",
                "delete",
                "declare_subscriber",
                "query",
                "reply",
                "declare_queryable",
                "liveliness_token",
                "liveliness_query",
                "declare_liveliness_subscriber",
            ],
            "flows": ["egress"],
            "permission": "allow",
            "key_exprs": ["skimesh/**", "@meshlink/**"],
        },
        _rule("read", ["declare_subscriber"], _READ),
        _rule("read-liveliness", _WATCH, ["skimesh/*/agents/*"]),
        _rule("read-queries", ["query"], _READ_QUERIES),
    ]
    rules, policies = list(everyone), []
    for c in components:
        own = _own_rules(c)
        rules.extend(own)
        policies.append({"id": c.name, "rules": [r["id"] for r in own], "subjects": [c.name]})
    policies.append(
        {"id": "everyone", "rules": [r["id"] for r in everyone], "subjects": list(names)}
    )
    return {
        "enabled": True,
        "default_permission": "deny",
        "rules": rules,
        "subjects": [{"id": c.name, "cert_common_names": [c.name]} for c in components],
        "policies": [p for p in policies if p["rules"]],
    }
