"""Compiled soil-model kernels behind one interface (:mod:`geocel.materials.kernels`)."""
