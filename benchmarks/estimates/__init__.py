"""Estimate error: ``python -m benchmarks.estimates [--scenario NAME ...] [--runs N] [--json F]``.

Each scenario's mission (``skimesh demo``'s goal) runs ``--runs`` times (default 2) in one
process with the MuJoCo world, each time in a fresh stack (router, store, world, agents, task
agent: as after a restart) that shares one learned-durations file: the first run is the
warm-up (estimated from the skill descriptions, as every task of a new site), each later run is
estimated from what the runs before it learned. Per run: the task's estimated and actual
makespan (``TaskFinished``, on the task agent's clock), the error, and the balance of the work
(the parallel makespan against the robots' total busy time divided by the robots; busy time
from the step events). The same-run baseline is the warm-up's estimate, made without learning.
By default the world steps as fast as it can, so its pace (and every duration on the task
agent's clock) follows the machine's load from run to run; ``--realtime`` paces it to the
clock, as a site's robots are. ``_allocation`` adds an in-process case: one robot three times
slower than the other, the measured task allocated with and without the learned durations.

``_run`` holds the whole benchmark: the runs, the rows, the command line.
"""

from ._run import Measured as Measured
from ._run import main as main
from ._run import measure as measure

__all__ = ["Measured", "main", "measure"]
