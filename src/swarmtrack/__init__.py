"""swarmtrack: cooperative target estimation and tracking by UAV swarms.

Source documents are cited by short name: L24 (Lizzio et al., Drones 2024), L23 (Lizzio et al., EASN 2022),
W20 (Wolfe, M.A.Sc. thesis 2020), IB21 (Ibenthal et al., Automatica 2021).
"""

__version__ = "0.5.0"


def load_run(path):
    """The recording of a ``swarmtrack run`` folder (or of its ``recording/`` folder): a
    :class:`~swarmtrack.sim.recorder.Recording`, whose ``frame("uavs")`` / ``frame("objects")`` are pandas views."""
    from pathlib import Path

    from swarmtrack.sim.recorder import Recording

    path = Path(path)
    return Recording.load(path / "recording" if (path / "recording").is_dir() else path)
