"""Thirty-sixth session: the verifier specification written for a model without the network
(test_verifier.py::test_the_shipped_model_rates_a_colour_distinct_region_above_a_product_coloured_one) asked
of a model that reads the network, as a shipped network cell would ask it: the same synthetic view, the regions'
features read with the network. Prints both probabilities and the threshold; exits 1 unless the odd region
reaches the threshold and the product one does not.

    python docs/experiments_s36/spec_with_network.py runs/s36/verifier_c2.json docs/experiments_s35/impurity_net.pt
"""
import json
import pathlib
import sys

import numpy as np

sys.path.insert(0, "scripts")
sys.path.insert(0, "tests/unit/impurity_attention")
import calibrate_attention as ca  # noqa: E402
import test_verifier as spec  # noqa: E402

from impurity_attention.core import verifier as ver  # noqa: E402


def main() -> int:
    model = ver.RegionVerifier.from_dict(json.loads(pathlib.Path(sys.argv[1]).read_text()))
    network = ca.read_network_option(pathlib.Path(sys.argv[2]))
    color, height, objects, impurity, product = spec.two_colour_view()
    maps = spec.conspicuity_of(color, objects)
    candidates = ver.candidate_features(color, height, objects, maps,
                                        [spec.region(impurity, 2.0), spec.region(product, 2.0)],
                                        network=network)
    odd, same = model.probability(np.array([features for _, features in candidates]))
    held = odd >= model.threshold > same
    print(f"impurity region {odd:.3f}, product region {same:.3f}, threshold {model.threshold:.3f}: "
          f"{'holds' if held else 'FAILS'}")
    return 0 if held else 1


if __name__ == "__main__":
    sys.exit(main())
