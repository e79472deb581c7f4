"""Stage 3, the scene: what one image shows, as plain data drawn from the config.

- :mod:`~sdcomp.scene.config`: :class:`GeneratorConfig`, every field declared once with its
  bounds and help (:mod:`~sdcomp.scene.settings`), TOML files;
- :mod:`~sdcomp.scene.presets`: the named presets (the paper's, ``seadronessee``);
- :mod:`~sdcomp.scene.objects`: objects of interest and clutter kinds by name, the asset
  keys (one per variant) each is drawn from;
- :mod:`~sdcomp.scene.params`: per-image random values (a value, a range or a list);
- :mod:`~sdcomp.scene.camera`: the pinhole drone camera: intrinsics, pose, every projection;
- :mod:`~sdcomp.scene.water`: the water and sky of an image (:class:`WaterParams`), water
  types;
- :mod:`~sdcomp.scene.look`, :mod:`~sdcomp.scene.look_table`: the drone camera's look per
  image;
- :mod:`~sdcomp.scene.scene`: :class:`Scene`, everything the pixels of one image depend on;
- :mod:`~sdcomp.scene.sample`: :func:`sample_scene`, the scene of image ``i``.
"""

from .scene import FeatureSeeds, Placement, Role, Scene, Shore, on_land

__all__ = ["FeatureSeeds", "Placement", "Role", "Scene", "Shore", "on_land"]
