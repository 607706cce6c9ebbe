"""Calibration of the cell to a product and camera: `python -m impurity_learning.calibrate SUBCOMMAND`.

Subcommands, in the order a user runs them (each writes into the directory given by --out and reads what
the earlier ones wrote there):

    network      the impurity network         -> OUT/impurity_net.pt
    verifier     the region verifier           -> OUT/verifier.json
    thresholds   attention's verifier threshold, last look and stall look -> OUT/attention_thresholds.json
    verdict      the grasp verdict's thresholds -> OUT/verdict.json
    episode-end  the height below which a cluster hides nothing -> OUT/episode_end.json

Every subcommand fits on the tuning split only (impurity_learning.splits: the default and tuning palettes,
tuning scene seeds) and refuses held-out palettes and evaluation seeds (CalibrationRefused).
"""

from .scenes import CalibrationRefused

__all__ = ["CalibrationRefused"]
