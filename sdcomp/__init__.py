"""sdcomp: synthetic aerial datasets of objects on water, with exact masks.

Submodules are imported on demand (``sdcomp.mesh``, ``sdcomp.atlas``, ...) so that
``python -m sdcomp.<module>`` starts fast and without import side effects.
"""

__version__ = "0.1.0"
