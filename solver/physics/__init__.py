"""The physics of the ball on the rim: parameters, equations of motion and contact forces of the
rolling and slipping phases, kinematics, free flight and the rolling <-> slipping maps.

Imports nothing of ``rimroll.solver.engine`` or ``rimroll.solver.analysis`` (docs/architecture.md).
"""
