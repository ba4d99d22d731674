"""The restart policy as a pure decision: restart or not, after how long."""

from __future__ import annotations

import signal
from collections.abc import Sequence

from ._schema import Restart

__all__ = ["describe_exit", "restart_delay"]


def restart_delay(
    policy: Restart, code: int, restarts: Sequence[float], now: float
) -> float | None:
    """Seconds to wait before starting again a process that ended with ``code`` (negative: by
    that signal) at ``now``, given the times of its earlier restarts; None: leave it ended."""
    if policy.policy == "no" or (policy.policy == "on-failure" and code == 0):
        return None
    recent = sum(1 for t in restarts if now - t < policy.window)
    if recent >= policy.max_restarts:
        return None
    return float(min(policy.backoff * 2**recent, policy.max_backoff))


def describe_exit(code: int) -> str:
    if code < 0:
        try:
            return f"killed by {signal.Signals(-code).name}"
        except ValueError:
            return f"killed by signal {-code}"
    return f"exit code {code}"
