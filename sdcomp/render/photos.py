"""The user's own empty-water photos as backgrounds (``--backgrounds DIR``).

Photos are listed once (sorted, so the choice per image is reproducible), read on demand and
kept resized in a small cache. Each image gets a random crop with the output's aspect ratio
covering at least 60 % of the photo's shorter side, resized to the output size.
"""

from __future__ import annotations

import warnings
from collections import OrderedDict
from pathlib import Path

import cv2
import numpy as np

from ..errors import UserError

EXTENSIONS = (".jpg", ".jpeg", ".png", ".bmp", ".tif", ".tiff", ".webp")
_CACHE = 32
#: largest photo accepted, pixels (a 150 MP photo is 450 MB decoded; a header claiming more
#: is most likely a decompression bomb, or at least not worth decoding for a background)
MAX_PIXELS = 150_000_000


def check_photo(path: Path) -> tuple[int, int]:
    """(width, height) from the header of the photo at ``path``, read without decoding the
    pixels; UserError naming the file when it is not a readable image or is larger than
    :data:`MAX_PIXELS` (e.g. a decompression bomb: a small file claiming a huge image)."""
    from PIL import Image  # Pillow comes with matplotlib

    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", Image.DecompressionBombWarning)
            with Image.open(path) as im:  # reads the header only
                w, h = im.size
    except Image.DecompressionBombError:
        w = h = -1  # larger than Pillow will even open
    except (OSError, ValueError, SyntaxError, Image.DecompressionBombWarning):
        raise UserError(f"--backgrounds: cannot read {path} as an image; remove or replace "
                        f"it") from None
    if w < 0 or w * h > MAX_PIXELS:
        size = f"{w} x {h} pixels" if w >= 0 else "over Pillow's bomb limit"
        raise UserError(f"--backgrounds: {path} claims {size}, more than "
                        f"{MAX_PIXELS // 1_000_000} megapixels (a decompression bomb?); "
                        f"downscale or remove it")
    if not cv2.haveImageReader(str(path)):
        raise UserError(f"--backgrounds: cannot read {path} as an image; remove or replace it")
    return w, h


def _truncated(path: Path, data: bytes) -> bool:
    """Whether a JPEG or PNG file stops before its end marker (an interrupted copy)."""
    if data[:3] == b"\xff\xd8\xff":
        return b"\xff\xd9" not in data[-4096:]
    if data[:8] == b"\x89PNG\r\n\x1a\n":
        return b"IEND" not in data[-4096:]
    return False


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
            check_photo(p)
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
        try:
            raw = path.read_bytes()
        except OSError as e:
            raise UserError(f"--backgrounds: cannot read {path} ({e.strerror}); remove or "
                            f"replace it") from None
        if _truncated(path, raw):
            raise UserError(f"--backgrounds: {path} is truncated (the file ends before the "
                            f"image does); remove or replace it")
        data = cv2.imdecode(np.frombuffer(raw, np.uint8), cv2.IMREAD_COLOR)
        if data is None:
            raise UserError(f"--backgrounds: cannot read {path} as an image; remove or "
                            f"replace it")
        img = cv2.cvtColor(data, cv2.COLOR_BGR2RGB)
        self._cache[i] = img
        if len(self._cache) > _CACHE:
            self._cache.popitem(last=False)
        return img

    def pick(self, seed: tuple[int, ...], width: int, height: int) -> np.ndarray:
        """The background for an image whose photo seed sequence is ``seed``
        (:attr:`sdcomp.scene.scene.FeatureSeeds.photo`): (height, width, 3) uint8."""
        rng = np.random.default_rng(list(seed))
        img = self._load(int(rng.integers(len(self.files))))
        ph, pw = img.shape[:2]
        aspect = width / height
        max_w = min(pw, ph * aspect)
        cw = max_w * rng.uniform(0.6, 1.0)
        ch = cw / aspect
        x0 = rng.uniform(0, pw - cw)
        y0 = rng.uniform(0, ph - ch)
        # at least one pixel each way (a crop under a pixel high, e.g. a 9 x 1 output, would
        # otherwise be empty)
        crop = img[int(y0):max(int(y0 + ch), int(y0) + 1), int(x0):max(int(x0 + cw), int(x0) + 1)]
        if rng.random() < 0.5:
            crop = crop[:, ::-1]
        interp = cv2.INTER_AREA if crop.shape[1] > width else cv2.INTER_LINEAR
        return cv2.resize(np.ascontiguousarray(crop), (width, height), interpolation=interp)
