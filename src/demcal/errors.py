"""User-facing errors.

A :class:`DemcalError` carries one sentence that names the problem and the fix.
The command line prints it as ``demcal: error: <sentence>`` and exits with status 2,
without a traceback. Library code raises it for every mistake a user can make
(bad file, unknown key, value out of range, a simulation that blew up); programming
errors stay ordinary exceptions.
"""


class DemcalError(Exception):
    """A user's mistake or an unusable input, explained in one sentence."""


class ConfigError(DemcalError):
    """A bad parameter, key or value in a configuration (campaign file, CLI option)."""


class DataError(DemcalError):
    """A bad data file: missing or non-numeric column, unreadable image, too few rows."""


class SimulationError(DemcalError):
    """A simulation that cannot go on (blow-up, NaN, particles escaping)."""
