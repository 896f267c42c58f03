"""Analysis of recorded runs: metrics, figures and paper reproductions.

Everything here reads :class:`swarmtrack.sim.recorder.Recording` objects, never live simulator state.
"""
