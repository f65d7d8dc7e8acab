"""Scenario presets shipped with coordarm: line, arc, hole (TOML data)."""
