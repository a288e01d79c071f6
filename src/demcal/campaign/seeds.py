"""The seeds of the runs the calibration loop adds, above the campaign's ``[runs] seed``.

A moved box's design runs at ``seed + BOX_SEED * box`` (its own design seeds,
:meth:`demcal.campaign.loop.Box.campaign`), a path point's replicate at
``seed + PATH_SEED + 997 * box + 10 * step + replicate``. The campaign file's check of
how far its seeds reach (:mod:`demcal.campaign.config`) reads the same numbers.
"""

#: Seeds of runs the loop adds: path points and moved boxes' designs (plus the
#: campaign's ``[runs] seed``); production runs use ``[verification] seed``.
PATH_SEED = 20_000
BOX_SEED = 50_000
#: Seeds of ``demcal identify``'s screening runs: ``seed + SCREEN_SEED + replicate * points
#: + point`` (:mod:`demcal.campaign.identify`), far above the loop's.
SCREEN_SEED = 900_000
#: Seeds of the hold-out runs (``[[holdout]]``): ``[verification] seed + HOLDOUT_SEED +
#: 1000 * condition + 100 * hold-out + replicate`` (:mod:`demcal.campaign.calibrate`).
HOLDOUT_SEED = 500_000
