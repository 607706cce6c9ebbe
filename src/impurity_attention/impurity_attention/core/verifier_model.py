"""The shipped region verifier (verifier.py), written by
`python scripts/calibrate_attention.py verifier-fit --write-model`
(tuning palettes and seeds only). Features in the order of verifier.FEATURES. Do not edit by hand: refit."""

from .verifier import RegionVerifier

MODEL = RegionVerifier(
    mean=(
        1.111578, 0.807619, 0.823088, 0.41023, 0.142573, 0.004544, -0.36407, 0.053401, 0.800105,
        1.446927, 0.140791, -1.711381
    ),
    scale=(
        0.494146, 0.881945, 0.878498, 0.758099, 0.292692, 0.005407, 1.615136, 0.170348, 0.761079,
        0.733836, 0.133675, 0.197882
    ),
    coef=(
        3.292888, 1.6395, 1.138472, 0.303653, 1.423526, -1.006562, 0.52894, 0.408697, -0.211424,
        -1.61001, -0.808615, 1.088453
    ),
    low=(
        0.036076, -2.834083, -2.56701, -2.631089, 0.0, 0.0, -10.924079, 0.0, 0.0, 0.0, 1.8e-05,
        -2.113002
    ),
    high=(
        3.201821, 3.127983, 3.237645, 2.838111, 1.0, 0.05335, 9.564821, 1.0, 2.0, 3.135494, 0.693147,
        -1.25892
    ),
    intercept=-0.933641,
    threshold=0.632975,
    provenance=(
        'scripts/calibrate_attention.py verifier-fit: 4659 tuning scenes, 106 palettes; on them '
        '97.9 % found, 1.0 % false TARGET'
    ),
)
