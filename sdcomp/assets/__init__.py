"""Stage 1, assets: the meshes objects are made of, in metres with face colours.

- :mod:`~sdcomp.assets.mesh`: :class:`ColoredMesh`, what every later stage draws;
- :mod:`~sdcomp.assets.solids`, :mod:`~sdcomp.assets.lofts`, :mod:`~sdcomp.assets.flotation`:
  manifold3d helpers the built-in meshes are made with (primitives, paint, lofts and sweeps,
  waterlines by displacement);
- :mod:`~sdcomp.assets.bluerov2`, :mod:`~sdcomp.assets.clutter`: the BlueROV2 and the
  distractors that exist only as clutter (logs, foam; the clutter's original buoy and
  dinghy);
- :mod:`~sdcomp.assets.sar`: the search-and-rescue objects, SeaDronesSee's five classes
  (swimmer, boat, jetski, life_saving_appliances, buoy), each in a set of variants;
- :mod:`~sdcomp.assets.meshfile`: a user's mesh file (STL, OBJ, PLY, GLB/GLTF, OFF);
- :mod:`~sdcomp.assets.library`: a mesh named by a built-in name or a path (:class:`MeshSpec`);
- :mod:`~sdcomp.assets.export`: writing a mesh to PLY, GLB or OBJ, and describing it.
"""
