"""The shipped region verifier (verifier.py), written by
`python scripts/calibrate_attention.py verifier-fit --write-model`
(tuning palettes and seeds only). Features named in `features`, in that order. Do not edit by hand: refit."""

from .verifier import RegionVerifier

MODEL = RegionVerifier(
    mean=(
        1.165352, 0.835669, 0.816556, 0.549831, 0.198693, 0.004365, -0.635405, 0.074516, 1.568323,
        -0.465211, 0.561919, 0.756001, 1.315685, 0.189634, -1.665987
    ),
    scale=(
        0.531573, 0.916286, 0.92127, 0.835409, 0.347067, 0.005063, 1.94308, 0.20963, 0.605653, 2.099167,
        0.425271, 0.771894, 0.758, 0.195779, 0.197027
    ),
    coef=(
        0.842008, 0.892516, 1.353462, 0.36451, 1.468404, -0.574769, -0.189758, 0.398609, 2.482871,
        1.816126, 0.639791, -0.213551, -1.093472, -1.042171, 0.49741
    ),
    low=(
        0.00172, -2.983519, -2.73637, -2.804864, 0.0, 0.0, -16.962339, 0.0, 0.261925, -16.851387, 0.0,
        0.0, 0.0, 1.8e-05, -2.113002
    ),
    high=(
        3.201821, 3.656135, 3.487449, 3.186067, 1.0, 0.05335, 9.564821, 1.0, 4.615121, 10.306804, 1.0,
        2.0, 3.135494, 0.693147, -1.247892
    ),
    intercept=0.276152,
    threshold=0.812515,
    provenance=(
        'scripts/calibrate_attention.py verifier-fit: 4029 tuning scenes and 3352 picking-loop '
        'views, 205 palettes, threshold on the scenes; on the scenes 97.1 % found, 1.0 % false '
        'TARGET, on the loop views 81.7 % found, 2.0 % false TARGET'
    ),
    features=(
        'colour_contrast', 'relative_rg', 'relative_by', 'relative_i', 'off_colour_share', 'height_spread',
        'lightness_offset', 'dark_share', 'oriented_contrast', 'oriented_lightness', 'oriented_off_share',
        'rank', 'log_regions', 'best_over_next', 'log_object_share'
    ),
)
