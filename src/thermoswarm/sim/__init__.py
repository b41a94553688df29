"""Simulation: world geometry, light and shadows, the engine."""
