"""The user's own empty-water photos as backgrounds (``--backgrounds DIR``).

Photos are listed once (sorted, so the choice per image is reproducible), read on demand and
kept resized in a small cache. Each image gets a random crop with the output's aspect ratio
covering at least 60 % of the photo's shorter side, resized to the output size.
"""

from __future__ import annotations

from collections import OrderedDict
from pathlib import Path

import cv2
import numpy as np

from .errors import UserError

EXTENSIONS = (".jpg", ".jpeg", ".png", ".bmp", ".tif", ".tiff", ".webp")
_CACHE = 32


class Backgrounds:
    """Photos in a folder; :meth:`pick` gives one as an (H, W, 3) uint8 RGB background."""

    def __init__(self, folder: str | Path):
        self.folder = Path(folder)
        if not self.folder.is_dir():
            raise UserError(f"--backgrounds {folder}: no such folder; give a folder of "
                            f"empty-water photos ({', '.join(EXTENSIONS)})")
        try:
            files = sorted(p for p in self.folder.iterdir()
                           if p.suffix.lower() in EXTENSIONS and p.is_file())
        except OSError as e:
            raise UserError(f"--backgrounds {folder}: cannot read the folder ({e})") from None
        if not files:
            raise UserError(f"--backgrounds {folder}: no photos in it; put empty-water "
                            f"photos ({', '.join(EXTENSIONS)}) there")
        for p in files:  # fail before writing anything: check every file's header
            if not cv2.haveImageReader(str(p)):
                raise UserError(f"--backgrounds: cannot read {p} as an image; remove or "
                                f"replace it")
        self.files = files
        self._cache: OrderedDict[int, np.ndarray] = OrderedDict()
        self._load(0)

    def __len__(self) -> int:
        return len(self.files)

    def _load(self, i: int) -> np.ndarray:
        img = self._cache.get(i)
        if img is not None:
            self._cache.move_to_end(i)
            return img
        path = self.files[i]
        data = cv2.imread(str(path), cv2.IMREAD_COLOR)
        if data is None:
            raise UserError(f"--backgrounds: cannot read {path} as an image; remove or "
                            f"replace it")
        img = cv2.cvtColor(data, cv2.COLOR_BGR2RGB)
        self._cache[i] = img
        if len(self._cache) > _CACHE:
            self._cache.popitem(last=False)
        return img

    def pick(self, seed: int, width: int, height: int) -> np.ndarray:
        """The background for an image with random ``seed``: (height, width, 3) uint8."""
        rng = np.random.default_rng([seed, 4])
        img = self._load(int(rng.integers(len(self.files))))
        ph, pw = img.shape[:2]
        aspect = width / height
        max_w = min(pw, ph * aspect)
        cw = max_w * rng.uniform(0.6, 1.0)
        ch = cw / aspect
        x0 = rng.uniform(0, pw - cw)
        y0 = rng.uniform(0, ph - ch)
        crop = img[int(y0):int(y0 + ch) or 1, int(x0):int(x0 + cw) or 1]
        if rng.random() < 0.5:
            crop = crop[:, ::-1]
        interp = cv2.INTER_AREA if crop.shape[1] > width else cv2.INTER_LINEAR
        return cv2.resize(np.ascontiguousarray(crop), (width, height), interpolation=interp)

    def mean_colour(self, seed: int) -> tuple[int, int, int]:
        """Mean sRGB colour of the photo :meth:`pick` chooses for ``seed``."""
        rng = np.random.default_rng([seed, 4])
        img = self._load(int(rng.integers(len(self.files))))
        m = img.reshape(-1, 3).mean(0)
        return int(m[0]), int(m[1]), int(m[2])
