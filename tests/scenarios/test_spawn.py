"""A swarm validate accepts, run places: the hexagonal lattice's capacity is what validation checks, and a swarm too
dense for random placement starts on that lattice, its UAVs min_separation apart inside the spawn box."""

import numpy as np
import pytest
from click.testing import CliRunner
from scipy.spatial.distance import pdist

from swarmtrack.cli import main
from swarmtrack.scenarios import load_scenario
from swarmtrack.scenarios.spawn import capacity, lattice
from swarmtrack.sim.build import spawn_positions


@pytest.mark.parametrize("half_width, separation", [(3, 1), (1, 1), (0.4, 1), (10, 0.7), (1, 0.3), (0.2, 0.5),
                                                    (5, 2.5), (1e3, 37.0)])
def test_the_lattice_holds_its_capacity_apart_and_inside_the_box(half_width, separation):
    nodes = lattice(half_width, separation)
    assert len(nodes) == capacity(half_width, separation)
    assert np.abs(nodes).max() <= half_width * (1 + 1e-12)
    if len(nodes) > 1:
        assert pdist(nodes).min() >= separation


@pytest.mark.parametrize("seed", range(3))
def test_a_swarm_too_dense_to_draw_at_random_starts_on_the_lattice(seed):
    scn = load_scenario("l24-ct", ["swarm.n_uavs=6", "swarm.spawn_half_width=1"], seed=seed)  # capacity 6
    pos = spawn_positions(scn, np.random.default_rng(seed))
    assert pos.shape == (6, 2) and pdist(pos).min() >= 1.0
    assert np.abs(pos - scn.swarm.spawn_center).max() <= 1.0 + 1e-12


def test_validate_and_run_refuse_a_swarm_the_box_cannot_hold_with_the_same_message(tmp_path):
    args = ["l24-ct", "--set", "swarm.n_uavs=7", "--set", "swarm.spawn_half_width=1"]
    checked = CliRunner().invoke(main, ["validate", *args])
    ran = CliRunner().invoke(main, ["run", *args, "--out", str(tmp_path / "run")])
    assert checked.exit_code == ran.exit_code == 2
    assert "cannot place 7 UAVs 1.0 m apart in a spawn box of half-width 1.0 m (it holds 6)" in checked.output
    assert checked.output == ran.output and not (tmp_path / "run").exists()
