"""Infrastructure every stage uses: atomic files, the worker pool, progress lines, logging,
sRGB transfer functions."""
