"""A ``kind`` that is not a string is a ConfigError, not a TypeError (found by hypothesis in test_scenario)."""
import pytest

from coordarm.symbolic import ConfigError, curve_from_spec, motion_from_spec


@pytest.mark.parametrize("kind", [[], {}, 3, None])
def test_unhashable_or_non_string_kind_is_a_config_error(kind):
    with pytest.raises(ConfigError, match=r"curve\.kind"):
        curve_from_spec({"kind": kind})
    with pytest.raises(ConfigError, match=r"speed\.kind"):
        motion_from_spec({"kind": kind}, "speed")
