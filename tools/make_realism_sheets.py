"""Contact sheet of default-settings images for docs/realism/: rows are (altitude m, pitch
degrees) = (5, 90), (15, 90), (40, 90), (15, 45), (40, 30), columns five images of seed 11,
annotated boxes in red. Writes OUT (JPEG) and a half-size OUT_view.png.

    python tools/make_realism_sheets.py docs/realism/sheet_after.jpg
    # the "before" sheet: the same script with PYTHONPATH=<a checkout of 8cc98f8>
"""
import sys

import cv2
import numpy as np

import sdcomp

try:
    from sdcomp import Generator, GeneratorConfig
except ImportError:
    from sdcomp.config import GeneratorConfig
    from sdcomp.generator import Generator
rows = [(5, 90), (15, 90), (40, 90), (15, 45), (40, 30)]
cols = 5
tiles = []
for alt, pitch in rows:
    g = Generator(GeneratorConfig(n=cols, seed=11, altitude=str(alt), pitch=str(pitch)))
    row = []
    for i in range(cols):
        s = g.sample(i)
        im = np.ascontiguousarray(s.image)
        for a in s.annotations:
            x, y, w, h = [int(round(v)) for v in a["bbox"]]
            cv2.rectangle(im, (x - 2, y - 2), (x + w + 1, y + h + 1), (255, 60, 60), 1)
        cv2.putText(im, f"{alt} m, pitch {pitch}", (6, 18), cv2.FONT_HERSHEY_SIMPLEX, 0.5,
                    (255, 255, 255), 1, cv2.LINE_AA)
        row.append(im)
    tiles.append(np.hstack(row))
sheet = np.vstack(tiles)
out = sys.argv[1]
cv2.imwrite(out, cv2.cvtColor(sheet, cv2.COLOR_RGB2BGR), [cv2.IMWRITE_JPEG_QUALITY, 88])
small = cv2.resize(sheet, (sheet.shape[1] // 2, sheet.shape[0] // 2), interpolation=cv2.INTER_AREA)
cv2.imwrite(out.rsplit(".", 1)[0] + "_view.png", cv2.cvtColor(small, cv2.COLOR_RGB2BGR))
print(sdcomp.__file__, sheet.shape)
