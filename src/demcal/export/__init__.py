"""Export a calibration as a material card: JSON, a LIGGGHTS snippet, EDEM's tables.

``demcal export CAMPAIGN --format json|liggghts|edem`` reads the campaign file and the
``calibration.json`` that ``demcal calibrate`` wrote, builds the card
(:func:`demcal.export.card.build_card`, a pure function) and formats it:

* ``json`` -- the card itself (:func:`demcal.export.card.to_json`);
* ``liggghts`` -- a block for a LIGGGHTS 3.8 input script (:mod:`demcal.export.liggghts`);
* ``edem`` -- the physics, material, interaction and particle tables for EDEM Creator
  (:mod:`demcal.export.edem`).

Each names the contact and rolling models the values assume in that code and says
plainly when they do not carry over (the card's ``transferable`` flag per code). The
card's ``warnings`` hold every reason not to trust it (a cheap profile, a condition not
verified, models the code lacks); the text formats start with them and ``demcal export``
says each on stderr.
"""

from __future__ import annotations

#: Format name -> "module:function" that turns a card into text.
FORMATS = {
    "json": "demcal.export.card:to_json",
    "liggghts": "demcal.export.liggghts:to_liggghts",
    "edem": "demcal.export.edem:to_edem",
}


def formatter(name: str):
    """The function that writes a card in format ``name`` (one of :data:`FORMATS`)."""
    import importlib

    module, function = FORMATS[name].split(":")
    return getattr(importlib.import_module(module), function)
