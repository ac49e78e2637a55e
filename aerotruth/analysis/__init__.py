"""Analysis: the wind paper's heading correction, wind metrics, FITS, ILS metrics."""
