"""Analysis of the dynamics: steady motions and their limits, Floquet multipliers, conserved
quantities, reduced dynamics, solution types, boundary types, predictability, adaptive maps, traces and the
scipy reference integration.

May import ``rimroll.solver.physics`` and ``rimroll.solver.engine`` (docs/architecture.md).
"""
