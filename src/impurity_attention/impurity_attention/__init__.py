"""RGB-D to heightmaps and the attention module (VOCUS2 saliency, DBSCAN)."""
