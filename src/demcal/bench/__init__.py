"""Virtual bench tests (angle of repose, inclined plane, impact)."""
