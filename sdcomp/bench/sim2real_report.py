"""The ``bench sim2real`` report: ``report.md`` from the result dict and ``detections.jpg``,
the real frames with their labels (green) and the detections (red, with scores) of the
detector as trained (left) and with its BatchNorm statistics re-estimated (right)."""

from __future__ import annotations

import cv2
import numpy as np

from .evaluate import BANDS

TILE_W = 640  #: pixels: each frame is drawn this wide
MAX_FRAMES = 6  #: frames in the figure: those with the most labelled boxes first
GREEN, RED = (40, 220, 60), (235, 40, 40)


def _fmt(v) -> str:
    return "-" if v is None or v < 0 else f"{100 * v:.1f}"


def _tile(rgb: np.ndarray, gt: list, dets: tuple, threshold: float, title: str
          ) -> np.ndarray:
    """(h, TILE_W, 3) uint8: the frame scaled to :data:`TILE_W` wide, boxes drawn after
    scaling (so small objects stay visible: a box is at least 7 px across)."""
    f = TILE_W / rgb.shape[1]
    img = np.ascontiguousarray(cv2.resize(rgb, (TILE_W, max(1, round(rgb.shape[0] * f))),
                                          interpolation=cv2.INTER_AREA))

    def box(x0, y0, x1, y1, colour, pad):
        cx, cy = (x0 + x1) * f / 2, (y0 + y1) * f / 2
        hw, hh = max((x1 - x0) * f / 2, 3.5) + pad, max((y1 - y0) * f / 2, 3.5) + pad
        cv2.rectangle(img, (round(cx - hw), round(cy - hh)), (round(cx + hw), round(cy + hh)),
                      colour, 2)
        return round(cx - hw), round(cy - hh)

    for x, y, w, h in gt:
        box(x, y, x + w, y + h, GREEN, 3)
    boxes, scores, _ = dets
    for b, s in zip(boxes, scores, strict=True):
        if s >= threshold:
            x, y = box(b[0], b[1], b[2], b[3], RED, 0)
            cv2.putText(img, f"{s:.2f}", (x, max(y - 3, 10)), cv2.FONT_HERSHEY_SIMPLEX, 0.4,
                        RED, 1, cv2.LINE_AA)
    cv2.rectangle(img, (0, 0), (TILE_W, 18), (0, 0, 0), -1)
    cv2.putText(img, title, (4, 13), cv2.FONT_HERSHEY_SIMPLEX, 0.45, (255, 255, 255), 1,
                cv2.LINE_AA)
    return img


def detections_figure(path, real, videos, before: list, after: list, threshold: float
                      ) -> None:
    """Write the JPEG of up to :data:`MAX_FRAMES` real frames, two tiles each (as trained,
    BatchNorm re-estimated), with labelled boxes and detections scoring >= ``threshold``."""
    from ..render.footage import read_source

    gt: dict[int, list] = {}
    for a in real.coco["annotations"]:
        gt.setdefault(a["image_id"] - 1, []).append(a["bbox"])
    order = sorted(range(len(real.sources)), key=lambda k: (-len(gt.get(k, [])), k))
    rows = []
    for k in order[:MAX_FRAMES]:
        rgb = read_source(real.sources[k], videos, "--real")
        name = real.sources[k].key
        rows.append(np.hstack([
            _tile(rgb, gt.get(k, []), before[k], threshold, f"{name}: as trained"),
            np.full((round(rgb.shape[0] * TILE_W / rgb.shape[1]), 6, 3), 255, np.uint8),
            _tile(rgb, gt.get(k, []), after[k], threshold,
                  f"{name}: BatchNorm re-estimated on real frames")]))
    width = max(r.shape[1] for r in rows)
    sheet = np.vstack([np.pad(r, ((0, 6), (0, width - r.shape[1]), (0, 0)),
                              constant_values=255) for r in rows])
    cv2.imwrite(str(path), cv2.cvtColor(sheet, cv2.COLOR_RGB2BGR),
                [cv2.IMWRITE_JPEG_QUALITY, 90])


def render_markdown(r: dict) -> str:
    """The report.md text of a :func:`.sim2real.run_sim2real` result."""
    mapping = ", ".join(f"{g} = {rl}" for g, rl in r["mapping"].items())
    lines = ["# sim2real", "",
             f"Trained on {r['train']['images']} generated images "
             f"({', '.join(r['train']['folders'])}; classes {', '.join(r['train']['classes'])})"
             f", scored on {r['real']['label']} at their own resolution; categories scored: "
             f"{mapping}.", "", f"**Verdict: {r['verdict']['text']}.**", ""]
    s = r["sizes"]
    if s["generated_median_px"] and s["real_median_px"]:
        lo, hi = s["generated_range_px"]
        lines += [f"Object size (sqrt of the box area): median {s['real_median_px']:.1f} px "
                  f"real, {s['generated_median_px']:.1f} px generated; "
                  f"{100 * s['real_inside_range']:.0f} % of the real objects within the "
                  f"generated 2-98 % range ({lo:.1f}-{hi:.1f} px)."]
        for name, a in s.get("aspects", {}).items():  # results before 2026-11-28: none
            lines[-1] += (f" Box height / width of {name}: median {a['real']:.2f} real, "
                          f"{a['generated']:.2f} generated.")
    if s["note"]:
        lines += ["", f"Warning: {s['note']}."]
    lines += ["", "COCO AP (IoU 0.50:0.95), AP50 and AR100 (x 100) by object size (box area: "
              "tiny < 16^2 px, small < 32^2, medium < 96^2, large); - where a band has no "
              "object.", "",
              "| set | band | boxes | AP | AP50 | AR100 |", "|---|---|---|---|---|---|"]
    sets = [("generated val", r["synthetic_val"]), ("real, as trained", r["real_before"]),
            ("real, BatchNorm re-estimated", r["real_after"])]
    for name, m in sets:
        if m is None:
            continue
        for band in BANDS:
            v = m["bands"][band]
            if band == "all" or v["boxes"]:
                lines.append(f"| {name} | {band} | {v['boxes']} | {_fmt(v['AP'])} | "
                             f"{_fmt(v['AP50'])} | {_fmt(v['AR100'])} |")
    if len(r["categories"]) > 1:
        lines += ["", "| category | real AP50 as trained | BatchNorm re-estimated |",
                  "|---|---|---|"]
        for name, cid in r["categories"].items():
            b, a = (m["categories"][cid]["all"]["AP50"] for m in (r["real_before"],
                                                                    r["real_after"]))
            lines.append(f"| {name} | {_fmt(b)} | {_fmt(a)} |")
    bn = r["batchnorm"]
    lines += ["", f"BatchNorm re-estimation: {bn['layers']} layers, statistics from "
              f"{bn['frames']} unlabelled frames of {bn['source']} (weights unchanged).", "",
              "![detections](detections.jpg)", "",
              "Green: labelled objects; red: detections (score shown) of the detector as "
              "trained (left) and with BatchNorm re-estimated (right).", "",
              f"Device {r['device']}; training {r['wall_s']['training']} s, scoring "
              f"{r['wall_s']['scoring']} s, {r['wall_s']['total']} s in all.", ""]
    return "\n".join(lines)
