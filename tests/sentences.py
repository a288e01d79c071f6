"""Checking the project's promise for bad input: one sentence, no traceback."""

import pytest

from demcal.errors import ConfigError


def one_sentence(call, error=ConfigError, full_stop=True) -> str:
    """The ``error`` message of ``call()``, checked to be one line with no traceback (and
    to end with a full stop if ``full_stop``)."""
    with pytest.raises(error) as info:
        call()
    message = str(info.value)
    assert "\n" not in message and "Traceback" not in message, message
    if full_stop:
        assert message.endswith("."), message
    return message
