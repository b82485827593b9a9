"""The outcome engine: methods (tableaus), the step attempt, event location, the rules of a
simulation, the phase systems, the scene kernels, ``simulate`` and its backends.

Imports ``rimroll.solver.physics``, never ``rimroll.solver.analysis`` (docs/architecture.md).
"""
