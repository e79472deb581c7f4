"""The commented TOML config that ``sdcomp fit`` writes: only the fitted keys, each with a
comment saying where its value came from; ``sdcomp generate --config`` and ``sdcomp video
--config`` read it (every other setting keeps its default)."""

from __future__ import annotations

from pathlib import Path

from ..scene.config import GeneratorConfig
from ..scene.settings import load_toml, toml_value
from ..util.files import atomic_path

#: (config key, comment) of every key written, in file order
KEYS: tuple[tuple[str, str], ...] = (
    ("width", "frame size the footage was measured at (pixels); the look's noise, blur and "
              "compression are drawn for this output size"),
    ("height", ""),
    ("camera", "the footage's field of view (--fov), its frames as the sensor"),
    ("fov", ""),
    ("sensor_px", ""),
    ("altitude", "metres"),
    ("pitch", "degrees below the horizon"),
    ("water", "water types whose rendered colour is nearest the footage's water colour"),
    ("turbidity", "covers the 10th-90th percentile of the frames' inverted turbidities"),
    ("wind", "m/s: texture (high-pass std), glitter and whitecaps"),
    ("sky", "skies drawn per image"),
    ("sun_elevation", "degrees: brightness and glitter"),
    ("look", "camera look preset: noise, sharpness, tone, vignetting"),
    ("exposure_bias", "stops over the auto exposure (brightness); unset: the look's draws"),
    ("wb_red", "white balance gains (colour cast); unset: the look's draws"),
    ("wb_blue", ""),
    ("contrast", "tone curve contrast (luminance spread); unset: the look's draws"),
    ("shot_noise", "sensor shot noise (noise); unset: the look's draws"),
    ("recording", "video (H.264/H.265 frames) or photo (JPEG)"),
    ("jpeg_quality", "compression of the written files (blockiness)"),
    ("motion_blur", "probability of motion blur (sharpness)"),
    ("defocus_blur", "probability of defocus blur (sharpness)"),
    ("grade", "the site grade (the camera's last stage: the water's colour distribution and "
              "detail mapped to the footage's), a file beside this one"),
)


#: how the first line of a config written by ``sdcomp fit`` begins
HEADER = "sdcomp fit of "


def config_text(config: GeneratorConfig, header: list[str], geometry_fitted: bool) -> str:
    """The TOML text of the fitted keys of ``config`` (see :data:`KEYS`), after ``header``
    comment lines; altitude and pitch only when ``geometry_fitted``, the camera only when
    fitted (custom, from ``--fov``)."""
    values = config.to_dict()
    lines = [f"# {h}" for h in header] + [""]
    for key, comment in KEYS:
        if key in ("altitude", "pitch") and not geometry_fitted:
            continue
        if key in ("camera", "fov", "sensor_px") and values["camera"] != "custom":
            continue
        if comment:
            lines.append(f"# {comment}")
        if values[key] is None:  # unset: TOML has no null
            lines.append(f"# {key} = (unset)")
        else:
            lines.append(f"{key} = {toml_value(values[key])}")
    return "\n".join(lines) + "\n"


def write_config(path: str | Path, text: str) -> GeneratorConfig:
    """Write ``text`` to ``path`` atomically, read it back as ``sdcomp generate --config``
    does and return that config (so a file that would not load is never left behind)."""
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    with atomic_path(path) as tmp:
        tmp.write_text(text)
        config = GeneratorConfig.from_mapping(load_toml(tmp), source=str(path))
    return config


def fitted_size(path: str | Path) -> tuple[int, int] | None:
    """(width, height) pixels a config written by ``sdcomp fit`` was fitted at (its noise,
    blur and compression were measured at that size), or None for any other config file."""
    try:
        text = Path(path).read_text(encoding="utf-8", errors="replace")
    except OSError:
        return None
    if not text.startswith(f"# {HEADER}"):
        return None
    data = load_toml(path)
    w, h = data.get("width"), data.get("height")
    return (w, h) if isinstance(w, int) and isinstance(h, int) else None


def size_warning(path: str | Path, width: int, height: int) -> str | None:
    """One line saying what changes when a config fitted at another size (or aspect) than
    ``width`` x ``height`` pixels generates at that size; None when it is no fitted config
    or the sizes agree."""
    size = fitted_size(path)
    if size is None or size == (width, height):
        return None
    fw, fh = size
    line = (f"--config {path} was fitted at {fw}x{fh} px; generating {width}x{height}: the "
            f"look's noise, blur and compression were fitted at {fw}x{fh} and are drawn for "
            f"the new size (to fit them at it: sdcomp fit --size {max(width, height)})")
    if abs(width / height - fw / fh) > 0.01 * fw / fh:
        line += (f"; the aspect differs from the footage's ({width / height:.2f} vs "
                 f"{fw / fh:.2f}), so the camera's pixels are not square and every object "
                 f"is stretched: keep {fw}:{fh}")
    return line
