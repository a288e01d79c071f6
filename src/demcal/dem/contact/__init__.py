"""Contact sub-models in fixed slots (normal, damping, tangential, rolling).

``registry`` maps names to integer ids and defines presets (``hertz_mindlin``,
``hysteretic_spring``, ``linear``); ``normal``, ``damping``, ``tangential`` and
``rolling`` hold the small pure kernels, one dispatch per slot; ``kernel.contact``
evaluates one contact through all four slots. See each module for equations and sources.
"""

from .registry import ContactModel, PRESETS  # noqa: F401
