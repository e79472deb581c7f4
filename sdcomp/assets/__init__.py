"""Stage 1, assets: the meshes objects are made of, in metres with face colours.

- :mod:`~sdcomp.assets.mesh`: :class:`ColoredMesh`, what every later stage draws;
- :mod:`~sdcomp.assets.solids`: manifold3d helpers the built-in meshes are made with;
- :mod:`~sdcomp.assets.bluerov2`, :mod:`~sdcomp.assets.clutter`: the built-in meshes;
- :mod:`~sdcomp.assets.meshfile`: a user's mesh file (STL, OBJ, PLY, GLB/GLTF, OFF);
- :mod:`~sdcomp.assets.library`: a mesh named by a built-in name or a path (:class:`MeshSpec`);
- :mod:`~sdcomp.assets.export`: writing a mesh to PLY, GLB or OBJ, and describing it.
"""
