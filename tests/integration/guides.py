"""Run the commands of the guides (``docs/guides/*.md``) as written; the convention is in
``docs/guides/README.md``.

A fenced block's info string says what it is: ``sh`` / ``bash`` blocks are shell commands and
``python`` blocks complete programs, both run in document order from the repository root; any
other info string (``toml``, ``text``, ``json5``, ...) is content or output, not run; a block
without one is an error (say what it is). An HTML comment right before a block's fence steers
it: ``<!-- guide: skip (reason) -->``, ``<!-- guide: ready "A" "B" -->`` (a background command,
``... &``, is ready when its log shows the next text), ``<!-- guide: exit N -->`` (the block's
commands exit N). ``<!-- guide: skip file (reason) -->`` on a line of its own skips every block
of the file.

Substitutions: ``127.0.0.1:7447`` becomes a free port, ``/tmp/`` a fresh temporary directory,
a ``skimesh`` command the test's ``python -m skimesh``. Every process a guide starts is ended by
its PID when the guide is done, whatever happened.
"""

from __future__ import annotations

import os
import re
import shlex
import signal
import subprocess
import sys
from collections.abc import Iterator
from dataclasses import dataclass, field
from pathlib import Path

from .procs import ROOT, Child

GUIDES = ROOT / "docs" / "guides"
SHELL = frozenset({"sh", "bash"})
PYTHON = frozenset({"python"})
TRANSCRIPT = frozenset({"console"})
"""Commands with their output (``$ `` prompts): they cannot run as written, so they need a skip."""
ENDPOINT = "127.0.0.1:7447"
_FENCE = re.compile(r"^(?P<indent>\s*)(?P<fence>```+|~~~+)(?P<info>[^`\s]*)")
_MARKER = re.compile(r"^\s*<!--\s*guide:\s*(?P<body>.*?)\s*-->\s*$")
_SKIMESH = re.compile(r"(^|[;&|(]\s*|\$\(\s*)skimesh\b")


class GuideError(AssertionError):
    """A guide breaks the convention, or one of its commands does not work as written."""


@dataclass
class Directives:
    skip: str = ""
    """The reason the block is not run ('' = run it)."""
    ready: list[str] = field(default_factory=list)
    exit: int = 0
    loads: str = ""
    """A TOML block that must load as this config format (``scenario``, ``agent``, ``task``)."""


@dataclass
class Block:
    path: Path
    line: int
    info: str
    text: str
    directives: Directives

    @property
    def where(self) -> str:
        return f"{self.path.relative_to(ROOT)}:{self.line}"

    @property
    def runnable(self) -> bool:
        return self.info in SHELL | PYTHON

    @property
    def commands_inside(self) -> bool:
        """Whether the block holds commands (so it must be run or skipped with a reason)."""
        return self.runnable or self.info in TRANSCRIPT


def parse_directives(body: str, where: str) -> Directives:
    out = Directives()
    if m := re.fullmatch(r"skip(?: file)? \((.+)\)", body.strip()):
        out.skip = m[1]  # the reason may hold any text
        return out
    for part in (p.strip() for p in body.split(";") if p.strip()):
        if part.startswith("skip"):
            raise GuideError(f"{where}: `skip` needs a reason in parentheses: {part!r}")
        if part.startswith("ready "):
            out.ready = re.findall(r'"([^"]+)"', part)
            if not out.ready:
                raise GuideError(f"{where}: `ready` needs quoted texts: {part!r}")
        elif m := re.fullmatch(r"exit (\d+)", part):
            out.exit = int(m[1])
        elif m := re.fullmatch(r"loads as (scenario|agent|task)", part):
            out.loads = m[1]
        else:
            raise GuideError(f"{where}: unknown guide directive {part!r}")
    return out


def blocks(path: Path) -> list[Block]:
    """Every fenced block of ``path`` with its directives (those of a file-wide skip too)."""
    lines = path.read_text(encoding="utf-8").splitlines()
    file_skip = ""
    for number, line in enumerate(lines, 1):
        m = _MARKER.match(line)
        if m and m["body"].startswith("skip file"):
            file_skip = parse_directives(m["body"], f"{path}:{number}").skip
    found: list[Block] = []
    i = 0
    while i < len(lines):
        fence = _FENCE.match(lines[i])
        if fence is None:
            i += 1
            continue
        close = re.compile(rf"^\s*{re.escape(fence['fence'])}\s*$")
        end = next((j for j in range(i + 1, len(lines)) if close.match(lines[j])), len(lines))
        indent = len(fence["indent"])
        text = "\n".join(line[indent:] for line in lines[i + 1 : end])
        where = f"{path.relative_to(ROOT)}:{i + 1}"
        directives = Directives()
        before = i - 1
        while before >= 0 and not lines[before].strip():
            before -= 1
        marker = _MARKER.match(lines[before]) if before >= 0 else None
        if marker and not marker["body"].startswith("skip file"):
            directives = parse_directives(marker["body"], where)
        if file_skip and not directives.skip:
            directives.skip = file_skip
        found.append(Block(path, i + 1, fence["info"], text, directives))
        i = end + 1
    return found


def guide_files() -> list[Path]:
    return sorted(p for p in GUIDES.glob("*.md") if p.name != "README.md")


def unclassified(path: Path) -> list[str]:
    """Blocks that break the convention: no info string (and not skipped)."""
    problems = []
    for b in blocks(path):
        if b.directives.skip:
            continue
        if not b.info:
            problems.append(f"{b.where}: a block without an info string (sh, python, text, ...)")
        elif b.info in TRANSCRIPT:
            problems.append(f"{b.where}: a `console` transcript cannot run: skip it with a reason")
    return problems


def commands(text: str) -> list[str]:
    """Shell commands of a block: continuation lines joined, blank and comment lines dropped."""
    out: list[str] = []
    pending = ""
    for raw in text.splitlines():
        line = pending + raw
        if line.rstrip().endswith("\\"):
            pending = line.rstrip()[:-1] + " "
            continue
        pending = ""
        if line.strip() and not line.lstrip().startswith("#"):
            out.append(line.strip())
    return out


@dataclass
class Session:
    """One guide's run: its substitutions and the processes it started."""

    port: int
    tmp: Path
    background: list[Child] = field(default_factory=list)
    log: list[str] = field(default_factory=list)

    def substitute(self, text: str) -> str:
        text = text.replace(ENDPOINT, f"127.0.0.1:{self.port}")
        return text.replace("/tmp/", f"{self.tmp}/")

    def run(self, block: Block) -> None:
        if block.info in PYTHON:
            self._python(block)
            return
        ready = list(block.directives.ready)
        script: list[str] = []  # consecutive foreground commands run as one script
        for command in commands(block.text):
            command = re.sub(r"\s&\s+#.*$", " &", command)  # `cmd &  # comment`
            if command.endswith("&") and not command.endswith("&&"):
                if script:
                    self._shell(block, script)
                    script = []
                self._start(block, command[:-1].strip(), ready.pop(0) if ready else "")
            else:
                script.append(command)
        if script:
            self._shell(block, script)

    def _check_endpoint(self, block: Block, command: str) -> None:
        for m in _SKIMESH.finditer(command):
            rest = command[m.end() :].split()
            if rest[:1] != ["demo"] and ENDPOINT not in command:
                raise GuideError(
                    f"{block.where}: `{command}` uses the default endpoint; write "
                    f"`--connect tcp/{ENDPOINT}` (or `--listen`) so the test can map it"
                )

    def _start(self, block: Block, command: str, ready: str) -> None:
        self._check_endpoint(block, command)
        argv = shlex.split(self.substitute(command))
        if argv[:1] != ["skimesh"]:
            raise GuideError(f"{block.where}: only `skimesh` commands run in the background")
        child = Child(["-m", "skimesh", *argv[1:]], name=command)
        self.background.append(child)
        self.log.append(f"started {command} (pid {child.pid})")
        if ready:
            try:
                child.wait_stderr(ready, timeout=120)
            except AssertionError as exc:
                message = f"{block.where}: `{command}` never logged {ready!r}: {exc}"
                raise GuideError(message) from None

    def _shell(self, block: Block, lines: list[str]) -> None:
        """Run ``lines`` as one ``bash -e`` script (shell variables carry over between them)."""
        for line in lines:
            self._check_endpoint(block, line)
        python = shlex.quote(sys.executable)
        script = "\n".join(
            _SKIMESH.sub(lambda m: f"{m[1]}{python} -m skimesh", self.substitute(line))
            for line in lines
        )
        command = "; ".join(lines)
        done = _run(["bash", "-e", "-c", script])
        self.log.append(f"$ {command}  -> {done.returncode}")
        if done.returncode != block.directives.exit:
            raise GuideError(
                f"{block.where}: `{command}` exited {done.returncode}, the guide expects "
                f"{block.directives.exit}\n--- stdout\n{done.stdout[-3000:]}\n--- stderr\n"
                f"{done.stderr[-3000:]}\n{self.logs()}"
            )

    def _python(self, block: Block) -> None:
        program = self.tmp / f"block-{block.line}.py"
        program.write_text(self.substitute(block.text), encoding="utf-8")
        done = _run([sys.executable, str(program)])
        self.log.append(f"python block {block.where} -> {done.returncode}")
        if done.returncode != block.directives.exit:
            raise GuideError(
                f"{block.where}: the program exited {done.returncode}\n--- stdout\n"
                f"{done.stdout[-3000:]}\n--- stderr\n{done.stderr[-3000:]}\n{self.logs()}"
            )

    def logs(self) -> str:
        return "\n".join(f"--- {c.name}\n{c.log()}" for c in self.background)

    def stop(self) -> None:
        """End every background process by its PID, newest first."""
        for child in reversed(self.background):
            child.stop()


def _run(argv: list[str], timeout: float = 300.0) -> subprocess.CompletedProcess[str]:
    """Run a foreground command in its own process group; on a time-out the whole group (the
    command and what it started) is killed by its id."""
    # `python` in a guide is the interpreter running the tests (its environment's bin first)
    path = os.pathsep.join([os.path.dirname(sys.executable), os.environ.get("PATH", "")])
    proc = subprocess.Popen(
        argv,
        cwd=ROOT,
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
        start_new_session=True,
        env=dict(os.environ, PATH=path),
    )
    try:
        out, err = proc.communicate(timeout=timeout)
    except subprocess.TimeoutExpired:
        os.killpg(proc.pid, signal.SIGKILL)
        out, err = proc.communicate()
        raise GuideError(
            f"`{argv[-1]}` ran over {timeout} s\n{out[-2000:]}\n{err[-2000:]}"
        ) from None
    return subprocess.CompletedProcess(argv, proc.returncode, out, err)


def run_guide(path: Path, port: int, tmp: Path) -> Iterator[Block]:
    """Run ``path``'s runnable blocks in order; yields each block run. Processes are stopped
    at the end even when a command fails."""
    session = Session(port, tmp)
    try:
        for block in blocks(path):
            if block.runnable and not block.directives.skip:
                session.run(block)
                yield block
    finally:
        session.stop()
