"""Does a real-time ``swarmtrack live`` run end cleanly on a busy machine? (issue 35: once one aborted at exit with
``FATAL: exception not rethrown``, exit −6.)

Starts ``--busy`` busy loops (``sh -c 'while :; do :; done'``, as many cores as given: default 2), runs ``--runs``
short real-time live runs one after another (``l24-ct`` with ``--uavs`` UAVs for ``--duration`` s of simulated time,
no figures, each into its own folder under a temporary folder removed at the end), ends the busy loops by their ids,
and counts the exit codes. Prints the load average and each run's exit code as it ends, then the counts; with
``--json`` the counts as JSON. Exit code 0 when every run exited 0, 1 otherwise.

With ``--sequence N`` it runs, beside the same busy loops, N times each way, a world process's last moments alone
(the node's heartbeat beating, the end of its live part, 0-0.25 s of Python work as the report, exit): ``transport``
closes the transport only, as the code before the fix did (the heartbeat thread then stops when a send fails);
``node`` is ``Node.close`` (the heartbeat stopped and joined, then the transport). Counted: exits by SIGABRT.

Usage: ``python benchmarks/live_exit_under_load.py [--runs 50] [--duration 3] [--uavs 2] [--busy 2] [--sequence N]
[--json]``.
"""

from __future__ import annotations

import argparse
import json
import os
import signal
import subprocess
import sys
import tempfile
import time
from collections import Counter
from pathlib import Path

#: A world process's last moments (argument: how its live part ends, ``transport`` or ``node``).
LAST_MOMENTS = """
import random, sys, time
from swarmtrack.live.node import Node
from swarmtrack.live.transport import ZenohTransport
from swarmtrack.live.wire import WORLD, Seal
node = Node(ZenohTransport(), Seal(None, 3), "exit-lab", WORLD)
node.listen(("uav", "*", "alive"))
node.heartbeat()
time.sleep(random.uniform(0.05, 0.45))
(node.transport.close if sys.argv[1] == "transport" else node.close)()
end = time.monotonic() + random.uniform(0.0, 0.25)
while time.monotonic() < end:
    pass
"""


def sequence(n: int) -> dict[str, dict[str, int]]:
    """Exit codes of ``n`` runs of :data:`LAST_MOMENTS` each way."""
    out = {}
    for how in ("transport", "node"):
        codes: Counter = Counter()
        for _ in range(n):
            codes[subprocess.run([sys.executable, "-c", LAST_MOMENTS, how], capture_output=True).returncode] += 1
        out[how] = {str(k): v for k, v in sorted(codes.items())}
    return out


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--runs", type=int, default=50)
    ap.add_argument("--duration", type=float, default=3.0)
    ap.add_argument("--uavs", type=int, default=2)
    ap.add_argument("--busy", type=int, default=2, help="busy loops beside the runs")
    ap.add_argument("--sequence", type=int, default=0, metavar="N",
                    help="instead: a world's last moments N times each way (see the module docstring)")
    ap.add_argument("--json", action="store_true")
    args = ap.parse_args()
    if args.sequence:
        busy = [subprocess.Popen(["sh", "-c", "while :; do :; done"]) for _ in range(args.busy)]
        try:
            counts = sequence(args.sequence)
        finally:
            for p in busy:
                p.send_signal(signal.SIGTERM)
                p.wait()
        print(json.dumps({"exit_codes": counts, "load_average_1min": os.getloadavg()[0]}, indent=None if not
                         args.json else 2))
        return 0 if all(set(c) == {"0"} for c in counts.values()) else 1
    busy = [subprocess.Popen(["sh", "-c", "while :; do :; done"]) for _ in range(args.busy)]
    codes: Counter = Counter()
    failures: list[str] = []
    loads: list[float] = []
    try:
        with tempfile.TemporaryDirectory(prefix="swarmtrack-exit-") as tmp:
            for r in range(args.runs):
                out = Path(tmp) / f"run{r}"
                cmd = [sys.executable, "-m", "swarmtrack", "live", "l24-ct", "--realtime", "--insecure", "--no-plots",
                       "--out", str(out), "--set", f"duration={args.duration:g}",
                       "--set", f"swarm.n_uavs={args.uavs}"]
                start = time.monotonic()
                try:
                    proc = subprocess.run(cmd, capture_output=True, text=True, timeout=300)
                    code, err = proc.returncode, proc.stderr
                except subprocess.TimeoutExpired as exc:
                    code, err = "timeout", (exc.stderr or b"").decode(errors="replace")
                codes[code] += 1
                loads.append(os.getloadavg()[0])
                if code != 0:
                    failures.append(f"run {r}: exit {code}: {err.strip().splitlines()[-3:]}")
                if not args.json:
                    print(f"run {r + 1}/{args.runs}: exit {code} in {time.monotonic() - start:.1f} s "
                          f"(load {loads[-1]:.2f})", flush=True)
    finally:
        for p in busy:  # only the loops this script started, by their ids
            p.send_signal(signal.SIGTERM)
            p.wait()
    result = {"runs": args.runs, "exit_codes": {str(k): n for k, n in sorted(codes.items(), key=str)},
              "load_average_1min": {"min": min(loads, default=0), "max": max(loads, default=0)},
              "failures": failures}
    if args.json:
        print(json.dumps(result, indent=2))
    else:
        print("exit codes:", result["exit_codes"], "; 1-min load average", result["load_average_1min"])
        for f in failures:
            print(" ", f)
    return 0 if set(codes) == {0} else 1


if __name__ == "__main__":
    sys.exit(main())
