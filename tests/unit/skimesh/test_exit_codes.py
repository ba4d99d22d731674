"""The one exit-code table (skimesh.errors.Exit): every error a user can act on gets the code of
its kind, and the command line turns it into one line (a traceback only with ``--debug``)."""

from __future__ import annotations

import pytest

from device_drivers import DeviceUnavailableError, MotionError
from meshlink import ConfigError, NoReplyError, SessionError
from skill_agent import (
    AgentTransportError,
    ParameterError,
    PreconditionError,
    RemoteSkillError,
    ResourceBusyError,
    SkillFailure,
    UnknownSkillError,
)
from skimesh import cli
from skimesh.commands import router
from skimesh.errors import Exit, UsageError, exit_code
from task_agent import (
    GoalParseError,
    PlannerTimeoutError,
    RemoteTaskError,
    TaskTransportError,
    UnsolvableError,
    VerificationError,
)
from wm_store import (
    ElementNotFoundError,
    RemoteError,
    RevisionTimeoutError,
    StorageError,
    TransportError,
    UnknownClassError,
)

CASES: list[tuple[BaseException, Exit]] = [
    (NoReplyError("skimesh/m/wm/query", 5.0), Exit.UNREACHABLE),
    (SessionError("cannot open"), Exit.UNREACHABLE),
    (TransportError("store gone"), Exit.UNREACHABLE),
    (RevisionTimeoutError("waited"), Exit.UNREACHABLE),
    (AgentTransportError("agent gone"), Exit.UNREACHABLE),
    (TaskTransportError("task agent gone"), Exit.UNREACHABLE),
    (DeviceUnavailableError("no arm"), Exit.UNREACHABLE),
    (TimeoutError(), Exit.UNREACHABLE),
    (RemoteTaskError("unavailable", "shutting down"), Exit.UNREACHABLE),
    (ElementNotFoundError("no element 'Gear-11'"), Exit.REFUSED),
    (UnknownClassError("unknown class 'Gaer'"), Exit.REFUSED),
    (UnknownSkillError("no skill 'pik'"), Exit.REFUSED),
    (ParameterError("no element 'Gear-11'"), Exit.REFUSED),
    (PreconditionError("the gripper holds something"), Exit.REFUSED),
    (ResourceBusyError("r1-arm is busy"), Exit.REFUSED),
    (GoalParseError("unknown element 'Gear-11'"), Exit.REFUSED),
    (VerificationError("does not verify"), Exit.REFUSED),
    (UnsolvableError("no plan"), Exit.REFUSED),
    (RemoteTaskError("unknown_task", "no task 't-1'"), Exit.REFUSED),
    (ConfigError("bad endpoint"), Exit.REFUSED),
    (UsageError("--set takes PROP=VALUE"), Exit.REFUSED),
    (FileNotFoundError("no file"), Exit.REFUSED),
    (SkillFailure("the grasp slipped"), Exit.FAILED),
    (PlannerTimeoutError("no plan in 10 s"), Exit.FAILED),
    (StorageError("disk full"), Exit.FAILED),
    (RemoteError("internal", "boom"), Exit.FAILED),
    (RemoteSkillError("internal", "boom"), Exit.FAILED),
    (MotionError("collision"), Exit.FAILED),
]


@pytest.mark.parametrize(("error", "code"), CASES, ids=lambda c: type(c).__name__)
def test_each_kind_of_error_has_its_exit_code(error: BaseException, code: Exit) -> None:
    assert exit_code(error) is code


def test_the_table_is_the_documented_one() -> None:
    assert {e.name: e.value for e in Exit} == {
        "OK": 0,
        "FAILED": 1,
        "REFUSED": 2,
        "UNREACHABLE": 3,
        "ABORTED": 4,
        "CONTRADICTED": 5,
        "PARTIAL": 6,
        "INTERRUPTED": 130,
    }


def _router_raises(monkeypatch: pytest.MonkeyPatch, error: BaseException) -> None:
    """``skimesh router`` raises ``error`` instead of running a router."""

    def run(_: object) -> int:
        raise error

    monkeypatch.setattr(router, "_run", run)


@pytest.mark.parametrize(("error", "code"), CASES[:3] + CASES[9:12] + CASES[22:24])
def test_main_prints_one_line_and_exits_with_the_code(
    error: BaseException,
    code: Exit,
    monkeypatch: pytest.MonkeyPatch,
    capsys: pytest.CaptureFixture[str],
) -> None:
    _router_raises(monkeypatch, error)
    assert cli.main(["router"]) == code
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and err.startswith("skimesh router: "), err
    assert "Traceback" not in err


def test_debug_shows_the_traceback(
    monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    group = BaseExceptionGroup("task group", [SystemExit("nothing to change: give --set")])
    _router_raises(monkeypatch, group)
    assert cli.main(["--debug", "router"]) == Exit.REFUSED
    err = capsys.readouterr().err
    assert "Traceback" in err and err.endswith("skimesh router: nothing to change: give --set\n")


def test_a_bug_still_shows_its_traceback(monkeypatch: pytest.MonkeyPatch) -> None:
    _router_raises(monkeypatch, KeyError("bug"))
    with pytest.raises(KeyError):
        cli.main(["router"])


def test_an_expected_error_is_logged_in_one_line_a_bug_with_its_traceback() -> None:
    import io
    import logging

    stream = io.StringIO()
    handler = logging.StreamHandler(stream)
    handler.addFilter(cli._expected_in_one_line)
    log = logging.getLogger("test.one-line")
    log.addHandler(handler)
    log.propagate = False
    try:
        for error in (DeviceUnavailableError("r2-base: no reply"), KeyError("bug")):
            try:
                raise error
            except Exception:
                log.exception("run %s: on_preempt failed", "r-1")
    finally:
        log.removeHandler(handler)
    first, *rest = stream.getvalue().splitlines()
    assert first == ("run r-1: on_preempt failed: DeviceUnavailableError: r2-base: no reply"), first
    assert rest[0] == "run r-1: on_preempt failed" and "Traceback" in rest[1], rest


def test_debug_goes_before_or_after_the_command(
    monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    _router_raises(monkeypatch, UsageError("no config file x.json5"))
    for argv in (["--debug", "router"], ["router", "--debug"]):
        assert cli.main(argv) == Exit.REFUSED
        assert "Traceback" in capsys.readouterr().err, argv
    assert cli.main(["router"]) == Exit.REFUSED
    assert "Traceback" not in capsys.readouterr().err
