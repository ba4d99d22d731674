"""Start-up time of the ``skimesh`` command: what a user waits for before any output.

    python -m benchmarks.cli            # 15 runs of each command
    python -m benchmarks.cli --quick    # 5 runs
    python -m benchmarks.cli --json results.json

Figures (wall time of a fresh ``python -m skimesh ...`` process, start to exit; median and
slowest over the runs, the commands interleaved so that a drift of the machine's load favours
none; results and method: ``docs/benchmarks.md``, section "Command start-up"):

1. ``skimesh --help``, ``skimesh --version`` and ``skimesh agents --help``, and the light
   commands that ask a live mesh (``agents``, ``skills r1``, ``wm get Gear-1``, ``task status``
   of a task nobody has) against a loopback site the benchmark starts (``_site``: router,
   store, agent r1 with simulated outcomes, task agent; ``--offline`` leaves it out), each
   beside ``python -c pass`` measured in the same run (the interpreter's own start-up);
2. the target: under 0.5 s each;
3. which of the heavy packages (the planners, MuJoCo, placo, rerun, rdflib) each command
   imported (none, by design: they load only in the commands that use them).

``_run`` holds the measurement, the results table and the command line; ``_site`` the
loopback site.
"""

from benchmarks.cli._run import COMMANDS, main, measure

__all__ = ["COMMANDS", "main", "measure"]
