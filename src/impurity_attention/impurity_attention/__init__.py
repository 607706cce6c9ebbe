"""RGB-D to heightmap projection and the attention module (VOCUS2 saliency, DBSCAN occluded-region inference)."""
