"""What the whole suite shares: numba's cache of the compiled kernels filled once, before the tests start.

On a fresh clone the cache is empty, and every process that calls a kernel first compiles it: both test workers, and
each process of a live run, the same kernels side by side (about 110 s more of the suite's wall time on 2 cores, and
a machine so busy that real-time runs miss their deadlines). Here two processes compile the built-in scenarios'
kernels (a 1 s run of each, split between them) before the workers start; with the cache filled they only load it.
"""

from __future__ import annotations

import subprocess
import sys

#: Run in each of the processes that fill the cache: a 1 s run of every built-in scenario of its share, and of IB21's
#: raster sets, which no built-in scenario uses and several tests do (their estimator's and SM-MPC's kernels: about
#: 30 s to compile, which each worker that came first to one of those tests paid).
WARM = """
import sys
from swarmtrack.analysis.sweep import warm
from swarmtrack.scenarios import builtin_names, load_scenario
part, parts = int(sys.argv[1]), int(sys.argv[2])
jobs = [("ib21-fleet-2", ["estimator.sets=raster"])] + [(name, []) for name in builtin_names()]
for name, overrides in jobs[part::parts]:
    warm(load_scenario(name, ["duration=1", *overrides]))
"""
PARTS = 2


def pytest_sessionstart(session) -> None:
    """On the process that starts the whole suite on several workers (``make test``; not on a worker, nor for a
    tier chosen with ``-m``, which compiles only what it calls): fill numba's cache, bounded in time."""
    config = session.config
    if hasattr(config, "workerinput") or not config.getoption("numprocesses", None) or config.getoption("markexpr"):
        return
    procs = [subprocess.Popen([sys.executable, "-c", WARM, str(part), str(PARTS)], stdout=subprocess.DEVNULL)
             for part in range(PARTS)]
    for proc in procs:
        try:
            proc.wait(timeout=600)
        except subprocess.TimeoutExpired:  # a bound against a hang: the tests compile what they need themselves
            proc.kill()
            proc.wait()
