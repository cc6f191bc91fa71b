"""The test suite's toy components live in the ``tests`` package: scenes in the tests name them as
``tests.toys:Source`` and so on, so that package is allowed as a source of component types
(``COSIM_COMPONENT_PACKAGES``, see :mod:`cosim.registry`), here and in every process a test starts."""

from __future__ import annotations

import os

from hypothesis import settings

from cosim.registry import ALLOW_ENV

# the demo scene fixture (``scene``) of the command-line tests; a module's own ``scene`` wins over it
pytest_plugins = ["tests.cli_toys"]

_allowed = [p for p in os.environ.get(ALLOW_ENV, "").split(",") if p.strip()]
if "tests" not in _allowed:
    os.environ[ALLOW_ENV] = ",".join([*_allowed, "tests"])

# Hypothesis' default deadline (200 ms an example) is a wall-clock assertion: on a loaded machine a
# correct example fails it. The tests assert behaviour, never time, so no example has a deadline;
# a test's own @settings still sets its own numbers (max_examples and so on) on top of this profile.
settings.register_profile("cosim", deadline=None)
settings.load_profile("cosim")
