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
