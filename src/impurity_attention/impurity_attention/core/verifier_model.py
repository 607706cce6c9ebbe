"""The shipped region verifier (verifier.py), written by
`python scripts/calibrate_attention.py verifier-fit --write-model`
(tuning palettes and seeds only). Features named in `features`, in that order. Do not edit by hand: refit."""

from .verifier import RegionVerifier

MODEL = RegionVerifier(
    mean=(
        1.166318, 0.839395, 0.819566, 0.542776, 0.200127, 0.004379, -0.620151, 0.074381, 0.753492,
        1.31162, 0.191356, -1.668533
    ),
    scale=(
        0.533251, 0.916895, 0.924055, 0.837282, 0.348368, 0.005081, 1.936808, 0.209612, 0.771488,
        0.761428, 0.197159, 0.19579
    ),
    coef=(
        2.295955, 1.014151, 1.524936, -0.314348, 1.67093, -0.631713, 0.574767, 0.503739, -0.381697,
        -1.194246, -0.692021, 0.550707
    ),
    low=(
        0.00172, -2.983519, -3.079303, -2.804864, 0.0, 0.0, -16.962339, 0.0, 0.0, 0.0, 1.8e-05,
        -2.113002
    ),
    high=(
        3.201821, 3.656135, 3.487449, 3.019829, 1.0, 0.05335, 9.564821, 1.0, 2.0, 3.135494, 0.693147,
        -1.247892
    ),
    intercept=0.185816,
    threshold=0.759879,
    provenance=(
        'scripts/calibrate_attention.py verifier-fit: 4029 tuning scenes and 3304 picking-loop '
        'views, 205 palettes, threshold on the scenes; on the scenes 96.7 % found, 1.0 % false '
        'TARGET, on the loop views 80.2 % found, 2.4 % false TARGET'
    ),
    features=(
        'colour_contrast', 'relative_rg', 'relative_by', 'relative_i', 'off_colour_share', 'height_spread',
        'lightness_offset', 'dark_share', 'rank', 'log_regions', 'best_over_next', 'log_object_share'
    ),
)
