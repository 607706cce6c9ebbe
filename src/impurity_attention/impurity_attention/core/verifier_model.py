"""The shipped region verifier (verifier.py), written by
`python scripts/calibrate_attention.py verifier-fit --write-model`
(tuning palettes and seeds only). Features named in `features`, in that order. Do not edit by hand: refit."""

from .verifier import RegionVerifier

MODEL = RegionVerifier(
    mean=(
        1.174104, 0.845074, 0.81169, 0.552753, 0.201728, 0.004381, -0.645921, 0.075982, 1.570146,
        -0.474948, 0.563958, 0.754201, 1.311333, 0.189078, -1.667056, 0.370969, 0.412564
    ),
    scale=(
        0.533232, 0.923233, 0.930113, 0.835558, 0.349551, 0.00507, 1.936083, 0.21129, 0.608441,
        2.096894, 0.4245, 0.771006, 0.757429, 0.196072, 0.196849, 0.433681, 0.448682
    ),
    coef=(
        -0.234229, 0.905753, 0.98868, 0.096648, 1.157171, -0.730809, -0.666206, 0.395172, 1.916154,
        1.356467, 0.682891, -0.35802, -0.864537, -1.123941, 0.289775, 1.089693, 1.507145
    ),
    low=(
        0.00172, -2.898417, -2.736363, -2.804864, 0.0, 0.0, -16.962339, 0.0, 0.261925, -16.851387, 0.0,
        0.0, 0.0, 1.8e-05, -2.113002, 9e-06, 1.8e-05
    ),
    high=(
        3.414046, 3.640097, 3.487449, 3.019829, 1.0, 0.05335, 9.564821, 1.0, 4.615121, 10.306804, 1.0,
        2.0, 3.135494, 0.693147, -1.247892, 0.999986, 1.0
    ),
    intercept=0.148715,
    threshold=0.738,
    provenance=(
        'scripts/calibrate_attention.py verifier-fit: 4029 tuning scenes and 3261 picking-loop '
        'views, 205 palettes, threshold on the scenes; on the scenes 98.3 % found, 1.0 % false '
        'TARGET, on the loop views 85.5 % found, 1.3 % false TARGET; threshold matched to the '
        "shipped model's false TARGETs (docs/experiments_s36/match_thresholds.py)"
    ),
    features=(
        'colour_contrast', 'relative_rg', 'relative_by', 'relative_i', 'off_colour_share', 'height_spread',
        'lightness_offset', 'dark_share', 'oriented_contrast', 'oriented_lightness', 'oriented_off_share',
        'rank', 'log_regions', 'best_over_next', 'log_object_share', 'network_mean', 'network_high'
    ),
)
