"""The shipped region verifier (verifier.py), written by
`python scripts/calibrate_attention.py verifier-fit --write-model`
(tuning palettes and seeds only). Features in the order of verifier.FEATURES. Do not edit by hand: refit."""

from .verifier import RegionVerifier

MODEL = RegionVerifier(
    mean=(
        1.116812, 0.842483, 0.847682, 0.444783, 0.15434, 0.004484, -0.372208, 0.057059, 0.787089,
        1.395625, 0.143469, -1.708301
    ),
    scale=(
        0.48433, 0.872672, 0.875925, 0.778979, 0.299857, 0.005486, 1.707082, 0.176803, 0.755889,
        0.721142, 0.137387, 0.20014
    ),
    coef=(
        3.483151, 1.461686, 0.97372, 0.144872, 1.463822, -0.978696, 0.57503, 0.359347, -0.224161,
        -1.412878, -0.802259, 1.082354
    ),
    low=(
        0.00172, -2.834083, -2.56701, -2.631089, 0.0, 0.0, -10.924079, 0.0, 0.0, 0.0, 1.8e-05, -2.113002
    ),
    high=(
        3.201821, 3.127983, 3.237645, 2.838111, 1.0, 0.05335, 9.564821, 1.0, 2.0, 3.135494, 0.693147,
        -1.25892
    ),
    intercept=-0.417323,
    threshold=0.693051,
    provenance=(
        'scripts/calibrate_attention.py verifier-fit: 4029 tuning scenes, 105 palettes; on them '
        '97.7 % found, 1.0 % false TARGET'
    ),
)
