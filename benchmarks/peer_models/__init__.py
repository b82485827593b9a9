"""Peer models: rimroll's scenes written for other integrators, to compare rimroll's engine with them.

``heyoka_rolling``: the rolling-only conservative scene in heyoka's expression system (the extra
``rimroll[bench]``), the ``heyoka_taylor`` integrator of the work-precision study and the peer of
``benchmarks/peers.py``. Installed as ``rimroll.peer_models``; imports the solver only.
"""
