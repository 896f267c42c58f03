"""Fingerprints of recordings: a refactor or a speed-up must leave every recorded number as it was.

Runs each scenario of :data:`RUNS` (seed 3, 60 s) in memory and prints, per run, the SHA-256 of every recorded
array: the truth of every world object, its phase index, and each probe, bit for bit. Measured wall times
(``solve_time``) are left out: they differ from run to run. Compare with an earlier fingerprint file::

    python benchmarks/fingerprint.py --json > before.json          # on the old code
    python benchmarks/fingerprint.py --compare before.json         # on the new code: IDENTICAL or the columns

Exit code 1 when a column differs (or a run or column is missing on one side).
"""

from __future__ import annotations

import argparse
import hashlib
import json
import sys

import numpy as np

#: name → (scenario, overrides); every run with seed 3 and duration 60 s.
RUNS = {
    "l24-ct": ("l24-ct", []),
    "l23-full-fusion": ("l23-full-fusion", []),
    "l24-imm": ("l24-imm", []),
    "robust-5": ("robust-5", []),
    # the clean camera of issue 26's runs (issue 27 put the error budget into w20-switching and w20-evasive-imm)
    "w20-switching": ("w20-switching-ideal", ["name=w20-switching"]),
    "w20-evasive-imm": ("w20-evasive-imm-ideal", ["name=w20-evasive-imm"]),
    "w20-mpc-formation": ("w20-mpc-formation", []),
    "ib21-fleet-6-polygons": ("ib21-fleet-6", ["estimator.sets=polygons"]),
    "ib21-fleet-6-raster": ("ib21-fleet-6", ["estimator.sets=raster"]),
}
#: Probes that measure wall time: not part of a fingerprint.
WALL_TIMES = ("solve_time",)


def _digest(a: np.ndarray) -> str:
    a = np.ascontiguousarray(a)
    return hashlib.sha256(f"{a.dtype}{a.shape}".encode() + a.tobytes()).hexdigest()[:16]


def fingerprint(scenario: str, overrides: list[str]) -> dict[str, str]:
    """Column name → digest of the whole run's array."""
    import swarmtrack

    rec = swarmtrack.simulate(swarmtrack.load_scenario(scenario, [*overrides, "duration=60"], seed=3))
    chunks = list(rec.chunks())
    out = {"t": _digest(np.concatenate([c.t for c in chunks])),
           "truth": _digest(np.concatenate([c.truth for c in chunks])),
           "phase": _digest(np.concatenate([c.phase for c in chunks]))}
    for name in sorted(rec.meta["probes"]):
        if name not in WALL_TIMES:
            out[f"probe:{name}"] = _digest(np.concatenate([c.probes[name] for c in chunks]))
    return out


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--json", action="store_true", help="print the fingerprints as JSON")
    ap.add_argument("--compare", metavar="FILE", help="compare with fingerprints printed earlier with --json")
    ap.add_argument("--only", action="append", help="run only this name of RUNS (repeatable)")
    args = ap.parse_args()
    names = args.only or list(RUNS)
    prints = {name: fingerprint(*RUNS[name]) for name in names}
    if args.json:
        print(json.dumps(prints, indent=1, sort_keys=True))
    if not args.compare:
        if not args.json:
            for name, cols in prints.items():
                print(name, _digest(np.frombuffer(json.dumps(cols, sort_keys=True).encode(), np.uint8)))
        return 0
    with open(args.compare) as f:
        before = json.load(f)
    bad = 0
    for name in names:
        old, new = before.get(name, {}), prints[name]
        diff = sorted(k for k in old.keys() | new.keys() if old.get(k) != new.get(k))
        print(f"{name}: {'IDENTICAL' if not diff else 'DIFFERS in ' + ', '.join(diff)}", file=sys.stderr)
        bad += bool(diff)
    return 1 if bad else 0


if __name__ == "__main__":
    sys.exit(main())
