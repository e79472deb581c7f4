"""The drone camera that records the rendered scene: lens (distortion, lateral chromatic
aberration, vignetting), exposure and white balance, tone curve, shot and read noise in linear
light, demosaicing softness, saturation, sharpening, block compression like a video codec or
JPEG (:func:`~sdcomp.render.camera.pipeline.apply_camera`), each parameter drawn per image
(:class:`~sdcomp.scene.look.CameraLook`).

- :mod:`~sdcomp.render.camera.pipeline`: the stages in order, the scale rule;
- :mod:`~sdcomp.render.camera.lens`: distortion and vignetting maps, label remapping;
- :mod:`~sdcomp.render.camera.photometric`: metering, white balance, tone curve tables;
- :mod:`~sdcomp.render.camera.sensor`: noise, Bayer mosaic and demosaicing, softness;
- :mod:`~sdcomp.render.camera.scale`: native-pixel effects reduced to the output scale;
- :mod:`~sdcomp.render.camera.codec`: sharpening and block compression.
"""

from .pipeline import STAGES, apply_camera

__all__ = ["STAGES", "apply_camera"]
