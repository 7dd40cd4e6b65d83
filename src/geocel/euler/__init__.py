"""Eulerian soil domain: Lagrangian phase and remap on the fixed grid."""
