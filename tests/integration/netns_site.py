"""The processes of one network-namespace test (:class:`Site`), on a
:class:`~tests.integration.netns.Lab`. Apart from ``netns.py``, which also runs as a script
inside the namespaces (its launcher), so it imports nothing of the package."""

from __future__ import annotations

import json
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from .netns import Lab
from .procs import Child

__all__ = ["Site"]


@dataclass
class Site:
    """One test's processes in a :class:`Lab`: a router on the hub at ``port``, and children
    by name. ``zenoh``: flags (a Zenoh config file) that go before every component's mesh
    flags."""

    lab: Lab
    mesh: str
    folder: Path
    port: int = 7447
    zenoh: tuple[str, ...] = ()
    children: dict[str, Child] = field(default_factory=dict)

    @property
    def endpoint(self) -> str:
        return f"tcp/{self.lab.address(self.lab.hub)}:{self.port}"

    def flags(self) -> list[str]:
        return [*self.zenoh, "--connect", self.endpoint, "--mesh", self.mesh]

    def start(self, name: str, host: str, *args: str, ready: str = "") -> Child:
        """``python ARGS`` on ``host``; with ``ready``, wait for that line on its stderr."""
        child = Child(self.lab.python(host, *args), name=name)
        self.children[name] = child
        if ready:
            child.wait_stderr(ready, timeout=60)
        return child

    def skimesh(self, name: str, host: str, *args: str, ready: str = "") -> Child:
        """``skimesh ARGS`` on ``host``, as :meth:`start`."""
        return self.start(name, host, "-m", "skimesh", *args, ready=ready)

    def ask(self, probe: Child, timeout: float = 60, **cmd: Any) -> dict[str, Any]:
        """Send a probe child one JSON command line; its JSON answer."""
        probe.send(json.dumps(cmd))
        answer = probe.next_json(timeout)
        assert answer is not None, f"the probe ended:\n{probe.log()}"
        return answer

    def logs(self) -> str:
        return "\n".join(f"--- {name}\n{child.log()}" for name, child in self.children.items())
