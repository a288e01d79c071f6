"""Particles: materials (engine helper), templates, size distributions, insertion (geometry helper)."""
