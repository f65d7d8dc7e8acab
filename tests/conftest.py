"""Shared fixtures and hypothesis settings."""
import os

import numpy as np
import pytest
from hypothesis import HealthCheck, settings

settings.register_profile("coordarm", deadline=None, max_examples=25,
                          suppress_health_check=[HealthCheck.too_slow])
settings.load_profile(os.environ.get("HYPOTHESIS_PROFILE", "coordarm"))


@pytest.fixture
def rng():
    return np.random.default_rng(20051)


@pytest.fixture(scope="session", autouse=True)
def build_dir(tmp_path_factory):
    """Compiled libraries built by the tests go to a session directory, never into the repo."""
    path = tmp_path_factory.mktemp("coordarm_build")
    old = os.environ.get("COORDARM_BUILD_DIR")
    os.environ["COORDARM_BUILD_DIR"] = str(path)
    yield path
    if old is None:
        os.environ.pop("COORDARM_BUILD_DIR", None)
    else:
        os.environ["COORDARM_BUILD_DIR"] = old
