"""``sdcomp fit`` (:func:`fit`, exported as ``sdcomp.fit``): the generator's scene settings
that make its images look like the user's own unlabelled footage (water, sky, light, the
camera's look), written as a config for ``sdcomp generate --config`` with a report.

:mod:`.stats` defines the statistics matched (the realism report's water statistics plus the
camera's), :mod:`.footage` reads and measures the frames, :mod:`.search` finds the settings
(water by colour inversion, the rest by a coordinate search on rendered frames),
:mod:`.config_file` writes the commented TOML and :mod:`.report` the markdown and picture;
:func:`fit` puts them together (docs/fit.md).
"""

from .api import FitResult, fit, fit_footage

__all__ = ["FitResult", "fit", "fit_footage"]
