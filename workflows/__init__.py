"""rimroll's named studies, one module per family; importing a module registers its studies.

The ``rimroll.studies`` entry points in pyproject.toml name each study and its module, so that
``study run NAME`` imports only the module of NAME (``study list`` imports them all).
"""
