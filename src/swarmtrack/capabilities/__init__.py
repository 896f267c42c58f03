"""The built-in capabilities, a package each: its settings, its builders and its registrations in one place.

=====================  ==================================================================================
``tracking_swarm``     L24, L23: range-bearing sensor, decentralized information filter (and its centralized
                       baseline), IMM bank, flocking
``static``             UAVs that hold their positions (W20 Ch. 4's trials)
``multi_model``        W20 Ch. 4: gimballed camera, multi-model distributed EKF
``mpc``                W20 Ch. 5: distributed MPC formation with the UAVs' identified model
``set_membership``     IB21: footprint sensor, set-membership estimator and MPC
``vehicles``           the vehicle kinds (L24 quadrotor, double integrator; IB21 walker, fixed wing), a module
=====================  ==================================================================================

Each package's ``__init__`` registers its kinds (:func:`swarmtrack.registry.register`) with its settings classes
(``settings.py``, validated by the scenario schema), its builders (``build.py``, referred to by name so that
validating a scenario imports no simulator code) and what the analysis reads of its runs. The algorithms
themselves live in the role folders (:mod:`swarmtrack.estimation`, :mod:`swarmtrack.control`,
:mod:`swarmtrack.sensors`), where a reader of the papers looks for them.
"""
