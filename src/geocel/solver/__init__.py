"""Time loop, stable time step, energies, Mass-Gravity-Scaling and geostatic state."""
