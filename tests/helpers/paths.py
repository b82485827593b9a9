"""Paths of the checkout that tests read: the repository's root and this folder of helpers (the scripts that
tests run in a process of their own or load by path: the probe study, the worker preload, the simulator probe)."""

import pathlib

HELPERS = pathlib.Path(__file__).resolve().parent
ROOT = HELPERS.parent.parent
