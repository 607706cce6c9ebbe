"""Calibration of the cell to a product and camera: `python -m impurity_learning.calibrate SUBCOMMAND`.

Subcommands, in the order a user runs them (each writes into the directory given by --out and reads what
the earlier ones wrote there):

    network           the impurity network -> OUT/impurity_net.pt
    verifier          the region verifier with attention's threshold, last look and stall look
                      -> OUT/verifier.json (impurity_attention.core.verifier.write_verifier's format)
    verdict           the grasp verdict's colour test -> OUT/verdict.json
    episode-end       the height below which a cluster hides nothing -> OUT/episode_end.json
    search-pushes     pushes at heaps without an impurity after which the bin is clean
                      -> OUT/search_pushes.json
    colour-reference  the simulator's Lab statistics for the heightmap node's colour adaptation
                      -> OUT/colour_reference.json

The cell reads impurity_net.pt and verifier.json from impurity_attention's checkpoints directory
(impurity_attention.core.checkpoints.shipped_path); the other results are node parameters.

Every subcommand fits on the tuning split only (impurity_learning.splits: the default and tuning palettes,
tuning scene seeds) and refuses held-out palettes and evaluation seeds (CalibrationRefused).
"""

from .scenes import CalibrationRefused

__all__ = ["CalibrationRefused"]
