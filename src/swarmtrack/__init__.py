"""swarmtrack: cooperative target estimation and tracking by UAV swarms.

Source documents are cited by short name: L24 (Lizzio et al., Drones 2024), L23 (Lizzio et al., EASN 2022),
W20 (Wolfe, M.A.Sc. thesis 2020), IB21 (Ibenthal et al., Automatica 2021).
"""

__version__ = "0.2.0"
