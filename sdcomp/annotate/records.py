"""Annotation records of a rendered frame: the one place that turns a :class:`Frame` into
COCO-style dicts (per object) and the image's metadata.

Two forms of the same objects: :func:`object_annotations` (the Python API's :class:`Sample`:
category names, no masks) and :func:`coco_annotations` (what the journal and the COCO files
hold: float boxes, RLE segmentation, ``iscrowd``, visibility, amodal masks when asked for).
:func:`camera_record` is the image's camera as BOP and Kubric record it (intrinsics ``K``,
no distortion, the world-to-camera pose).
"""

from __future__ import annotations

from collections.abc import Mapping

import numpy as np

from ..render.water.optics import beam_attenuation, iops, swatch
from ..scene.camera import camera_basis
from ..scene.scene import Placement, Role
from .masks import Frame, Instance
from .rle import crop_to_rle, mask_to_rle


def pose_of(pl: Placement) -> dict:
    """The placement's pose as annotations record it: degrees and metres, rounded."""
    return {"heading_deg": round(pl.heading % 360.0, 3),
            "roll_deg": round(pl.roll, 3), "pitch_deg": round(pl.pitch, 3),
            "draft_m": round(pl.draft, 4), "x_m": round(pl.x, 3),
            "y_m": round(pl.y, 3)}


def object_annotations(frame: Frame, names: Mapping[int, str]) -> list[dict]:
    """Per annotated object: instance_id, category_id, category (its name in ``names``,
    category id -> name), bbox [x, y, w, h] pixels, area pixels, pose."""
    return [{"instance_id": inst.instance_id, "category_id": inst.category_id,
             "category": names[inst.category_id], "bbox": list(inst.bbox),
             "area": inst.area, "pose": pose_of(frame.scene.placements[inst.placement])}
            for inst in frame.objects]


def ignore_annotations(frame: Frame) -> list[dict]:
    """Per ignored object (visible but not labelled: :class:`~sdcomp.annotate.masks.
    AnnotationRule`), the journal's ignore region: category_id (the object's), bbox
    [x, y, w, h] (floats) and area of its visible pixels, segmentation (compressed RLE of
    the image's ignore mask inside that box) and iscrowd 1, which COCOeval takes as "match
    a detection here to nothing": neither a true nor a false positive."""
    if frame.ignore is None:
        return []
    out = []
    for inst in frame.ignored:
        x, y, w, h = inst.bbox
        crop = frame.ignore[y:y + h, x:x + w]
        out.append({"category_id": inst.category_id, "bbox": [float(v) for v in inst.bbox],
                    "area": inst.area,
                    "segmentation": crop_to_rle(crop, x, y, *frame.ignore.shape),
                    "iscrowd": 1, "truncated": inst.truncated})
    return out


def coco_annotations(frame: Frame) -> list[dict]:
    """Per annotated object, the journal's (and COCO files') annotation: instance_id,
    category_id, bbox [x, y, w, h] (floats: pixel edges of the mask's extent), area,
    segmentation (compressed RLE of the mask), iscrowd 0, truncated (the frame's edge cuts
    it), visibility (visible mask pixels over the unoccluded in-frame silhouette's, 0-1, as
    BOP's ``visib_fract``), pose, and with amodal masks amodal_segmentation, amodal_area,
    amodal_bbox."""
    return [_coco_annotation(frame, inst) for inst in frame.objects]


def _coco_annotation(frame: Frame, inst: Instance) -> dict:
    x, y, w, h = inst.bbox
    crop = frame.instances[y:y + h, x:x + w] == inst.instance_id
    rec = {"instance_id": inst.instance_id, "category_id": inst.category_id,
           "bbox": [float(v) for v in inst.bbox], "area": inst.area,
           "segmentation": crop_to_rle(crop, x, y, *frame.instances.shape), "iscrowd": 0,
           "truncated": inst.truncated,
           "visibility": round(min(inst.area / inst.silhouette_area, 1.0), 4)
           if inst.silhouette_area else 1.0,
           "pose": pose_of(frame.scene.placements[inst.placement])}
    if inst.amodal is not None:
        rec["amodal_segmentation"] = mask_to_rle(inst.amodal)
        rec["amodal_area"] = inst.amodal_area
        ys, xs = np.nonzero(inst.amodal)
        rec["amodal_bbox"] = ([float(xs.min()), float(ys.min()), float(xs.max() - xs.min() + 1),
                               float(ys.max() - ys.min() + 1)] if len(xs)
                              else [0.0, 0.0, 0.0, 0.0])
    return rec


def dji_heading(heading: float) -> float:
    """DJI's gimbal yaw (degrees clockwise from north, -180 to 180) of a camera heading in
    sdcomp's world frame (degrees counter-clockwise from +x; +x east, +y north, z up)."""
    return (90.0 - heading + 180.0) % 360.0 - 180.0


def camera_record(frame: Frame, preset: str = "") -> dict:
    """The image's camera, as BOP (``cam_K``, ``cam_R_w2c``, ``cam_t_w2c``) and Kubric
    record it: ``K`` 3x3 pixels in OpenCV's convention (pixel (0, 0)'s centre at (0, 0), so
    cx = width / 2 - 0.5) and ``dist_coeffs`` (k1, k2, p1, p2, k3) of the recorded image
    (the camera stage's lens: its zoom scales the focal lengths; all 0 without it), the image
    size, the sensor (``preset`` name, native pixels, diagonal FOV degrees), and the pose:
    ``R_w2c`` (3x3, rows = camera x right, y down, z forward in world axes: x east, y north,
    z up, metres, the sea at z = 0) and ``t_w2c`` metres, so x_cam = R_w2c @ x_world +
    t_w2c."""
    model, pose = frame.scene.model, frame.scene.camera
    rot = camera_basis(pose.pitch, pose.heading)
    t = -rot @ pose.position
    zoom = float(frame.camera.get("zoom", 1.0))
    dist = [round(float(v), 9) + 0.0 for v in frame.camera.get("dist", [0.0] * 5)]
    return {"K": [[round(model.fx * zoom, 6), 0.0, model.width / 2 - 0.5],
                  [0.0, round(model.fy * zoom, 6), model.height / 2 - 0.5], [0.0, 0.0, 1.0]],
            "dist_coeffs": dist, "width": model.width, "height": model.height,
            "sensor": {"preset": preset, "width_px": model.sensor_width,
                       "height_px": model.sensor_height,
                       "diagonal_fov_deg": round(float(model.diagonal_fov), 6)},
            "R_w2c": [[round(float(v), 9) + 0.0 for v in row] for row in rot],
            "t_w2c": [round(float(v), 6) + 0.0 for v in t]}


def image_meta(frame: Frame) -> dict:
    """Per-image metadata (names follow SeaDronesSee's ``meta`` where they overlap;
    ``gimbal_heading(degrees)`` and ``sun_azimuth(degrees)`` in DJI's convention: clockwise
    from north, -180 to 180, so that their difference is the view's angle from the sun): the
    camera's pose and ground sampling distance, the water (its name, type, constituents,
    mean beam attenuation, colour swatch), waves, sky and sun, what else is in the frame,
    and what the camera did (look preset, stages, exposure, blur; its intrinsics and
    distortion are in :func:`camera_record`)."""
    s = frame.scene
    w = s.water
    a, bb = iops(w.chl, w.cdom, w.tsm)
    cam = frame.camera
    motion = cam.get("motion_px", 0.0) if "motion" in cam.get("stages", ()) else 0.0
    return {
        "height_above_takeoff(meter)": round(s.camera.altitude, 4),
        "gimbal_pitch(degrees)": round(s.camera.pitch, 4),
        "gimbal_heading(degrees)": round(dji_heading(s.camera.heading), 4),
        "gsd(m/px)": round(frame.gsd, 6),
        "water_color": w.name,
        "water_type": w.water_type,
        "water_rgb": list(w.rgb) if w.rgb is not None else list(swatch(a, bb)),
        "chlorophyll(mg/m3)": round(w.chl, 4),
        "cdom(1/m)": round(w.cdom, 4),
        "suspended_solids(g/m3)": round(w.tsm, 4),
        "turbidity": round(w.turbidity, 4),
        "attenuation(1/m)": round(float(np.mean(beam_attenuation(a, bb))), 5),
        "shallow_depth(meter)": None if w.depth is None else round(w.depth, 3),
        "wind(m/s)": round(w.wind, 3),
        "swell_height(meter)": round(w.swell_height, 3),
        "sky": w.sky,
        "cloud_cover": round(w.cloud_cover, 3),
        "sun_elevation(degrees)": round(w.sun_elevation, 3),
        "sun_azimuth(degrees)": round(dji_heading(w.sun_azimuth), 3),
        "shore": s.shore is not None,
        "hills": s.hills is not None,
        "clutter": s.count(Role.CLUTTER),
        "objects_placed": s.count(Role.OBJECT),
        "objects_dropped": frame.dropped,
        "objects_truncated": frame.truncated,
        "objects_ignored": len(frame.ignored),
        "objects_skipped": frame.skipped,
        "camera_look": s.look.preset,
        "recording": s.look.recording,
        "exposure_gain": round(float(cam.get("exposure_gain", 1.0)), 4),
        "motion_blur_px": round(float(motion), 3),
        "defocus_sigma_px": round(s.defocus_blur, 3) if s.defocus_blur else 0.0,
        "camera_stages": list(cam.get("stages", ())),
    }
