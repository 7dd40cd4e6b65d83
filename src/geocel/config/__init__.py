"""Typed, validated configuration (scenario file ↔ Python objects)."""
