"""Shared runs of the analysis tests (simulated once per session, on first use)."""

from __future__ import annotations

import pytest

from swarmtrack.sim.recorder import Recording


@pytest.fixture(scope="session")
def ib21_run(tmp_path_factory) -> Recording:
    """A 4 s ib21-fleet-6 run (6 UAVs, 3 targets, 3 decoys) streamed to disk in chunks of 7 steps, so chunks end
    mid-bin and between plans."""
    from swarmtrack.scenarios import load_scenario
    from swarmtrack.sim import recorder
    from swarmtrack.sim.engine import simulate

    path = tmp_path_factory.mktemp("ib21") / "rec"
    with pytest.MonkeyPatch.context() as mp:
        mp.setattr(recorder, "CHUNK_ROWS", 7 * 12)  # 12 objects: 3 targets, 3 decoys, 6 UAVs
        simulate(load_scenario("ib21-fleet-6", ["duration=4"]), record_to=path)
    rec = Recording.load(path)
    assert rec.meta["chunk_steps"] == 7 < rec.meta["n_steps"] == 80
    return rec
