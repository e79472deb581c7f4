"""The realism report: how real a generated dataset looks, as numbers (``sdcomp realism``).

Per-patch statistics of empty water (saturation, luminance, high-pass std, glint;
:mod:`.patches`) against the targets (PASS/FAIL, :mod:`.targets`), luminance power
spectra (:mod:`.spectrum`), side-by-side crops of objects and empty water at one ground
sampling distance (:mod:`.crops`), and, given real frames, a real-vs-synthetic patch
classifier whose cross-validated accuracy is the realism number: 0.5 = indistinguishable
(:mod:`.classifier`). :mod:`.sources` reads the generated dataset and the real footage
(:mod:`.sea` keeps sky and land out of "empty water"), :mod:`.analysis` measures a set,
:mod:`.report` writes the report (:func:`realism_report`). Per-object appearance
(``--objects``): :mod:`.objects` measures boxes against the water around them,
:mod:`.object_sets` a whole set (:func:`object_statistics`). Definitions: docs/realism.md.
"""

from .object_sets import object_statistics
from .report import FILES, realism_report

__all__ = ["FILES", "object_statistics", "realism_report"]
