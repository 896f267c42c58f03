"""What the whole suite shares: numba's cache of the compiled kernels filled once, before the tests start.

On a fresh clone the cache is empty, and every process that calls a kernel first compiles it: both test workers, and
each process of a live run, the same kernels side by side (about 110 s more of the suite's wall time on 2 cores, and
a machine so busy that real-time runs miss their deadlines). Here two processes compile the built-in scenarios'
kernels (a 1 s run of each, split between them) before the workers start; with the cache filled they only load it.
"""

from __future__ import annotations

import subprocess
import sys

#: Run in each of the processes that fill the cache: a 1 s run of every built-in scenario of its share, of IB21's
#: raster sets, which no built-in scenario uses and several tests do (their estimator's and SM-MPC's kernels: about
#: 30 s to compile, which each worker that came first to one of those tests paid), and of a sparse swarm of 1,000
#: UAVs (the proximity graph's strips, the sums and flocking over CSR links, the metrics' close pairs: about 25 s);
#: and the FS cycle with C-ordered states, as its tests call it (a run's are views: another signature, 7 s).
WARM = """
import sys
import numpy as np
from swarmtrack.analysis.sweep import warm
from swarmtrack.scenarios import builtin_names, load_scenario
part, parts = int(sys.argv[1]), int(sys.argv[2])
sparse = ["swarm.n_uavs=1000", "network.topology=proximity", "swarm.spawn_half_width=20"]
jobs = [("ib21-fleet-2", ["estimator.sets=raster"]), ("l24-cv", sparse)] + [(name, []) for name in builtin_names()]
for name, overrides in jobs[part::parts]:
    warm(load_scenario(name, ["duration=1", *overrides]))
if part == parts - 1:
    from swarmtrack.estimation.kernels import fs_cycle
    x, P = np.zeros((1, 12)), np.broadcast_to(np.eye(12), (1, 12, 12)).copy()
    fs_cycle(x, P, 0.05, np.ones(12), np.eye(2)[None].copy(), np.zeros((1, 2)), 1.0, 1.0, 1.0, 9.81, 0.0)
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
