"""Element-test driver: single material point under mixed stress/strain control."""
