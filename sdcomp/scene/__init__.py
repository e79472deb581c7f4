"""Stage 3, the scene: what one image shows, as plain data drawn from the config.

- :mod:`~sdcomp.scene.config`: :class:`GeneratorConfig`, every field declared once with its
  bounds and help (:mod:`~sdcomp.scene.settings`), presets, TOML files;
- :mod:`~sdcomp.scene.params`: per-image random values (a value, a range or a list);
- :mod:`~sdcomp.scene.camera`: the pinhole drone camera: intrinsics, pose, every projection;
- :mod:`~sdcomp.scene.water`: water colours and turbidity;
- :mod:`~sdcomp.scene.scene`: :class:`Scene`, everything the pixels of one image depend on;
- :mod:`~sdcomp.scene.sample`: :func:`sample_scene`, the scene of image ``i``.
"""

from .scene import FeatureSeeds, Placement, Role, Scene, Shore, on_land

__all__ = ["FeatureSeeds", "Placement", "Role", "Scene", "Shore", "on_land"]
