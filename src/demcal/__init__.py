"""demcal: calibrate DEM contact parameters from bench tests."""
__version__ = "0.1.0"
