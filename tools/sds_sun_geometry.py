"""Derive the ``seadronessee`` preset's view of the sun (sdcomp/scene/presets.py,
``SDS_HEADING`` and ``SDS_SUN_ELEVATION``) from SeaDronesSee's val annotations; run from the
repository root: ``python tools/sds_sun_geometry.py [instances_val.json]`` (default
``../shared/reference/seadronessee/instances_val.json``).

The preset draws (altitude, pitch) pairs from 100 of the 1030 frames with flight metadata:
sorted by altitude then pitch, the frame at ``int((i + 0.5) * 1030 / 100)`` for i = 0..99.
For the same frames this script computes the sun's elevation and compass azimuth from the
frame's UTC time, latitude and longitude (NOAA's low-precision solar position: the
equation of time and declination as Fourier series of the day of year, about 0.2 degrees
off near noon), and the camera's heading relative to the sun in sdcomp's convention
(azimuths from +x towards +y, counter-clockwise seen from above, with the sun at azimuth
0): ``(sun compass azimuth - gimbal heading) mod 360``, compass azimuths running clockwise.
It checks that its (altitude, pitch) pairs are the preset's and prints the two lists.
"""
from __future__ import annotations

import datetime as dt
import json
import math
import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent.parent))

from sdcomp.scene.presets import SDS_ALTITUDE, SDS_PITCH  # noqa: E402

DEFAULT = Path(__file__).resolve().parent.parent.parent / "shared/reference/seadronessee" \
    / "instances_val.json"


def solar_position(when: dt.datetime, lat: float, lon: float) -> tuple[float, float]:
    """(elevation, compass azimuth) of the sun in degrees at UTC time ``when`` seen from
    latitude ``lat`` and longitude ``lon`` (degrees, east positive)."""
    day = when.timetuple().tm_yday
    hours = when.hour + when.minute / 60 + when.second / 3600
    g = 2 * math.pi / 365 * (day - 1 + (hours - 12) / 24)
    eqt = 229.18 * (0.000075 + 0.001868 * math.cos(g) - 0.032077 * math.sin(g)
                    - 0.014615 * math.cos(2 * g) - 0.040849 * math.sin(2 * g))
    decl = (0.006918 - 0.399912 * math.cos(g) + 0.070257 * math.sin(g)
            - 0.006758 * math.cos(2 * g) + 0.000907 * math.sin(2 * g)
            - 0.002697 * math.cos(3 * g) + 0.00148 * math.sin(3 * g))
    hour_angle = math.radians((hours * 60 + eqt + 4 * lon) / 4 - 180)
    phi = math.radians(lat)
    cos_z = (math.sin(phi) * math.sin(decl)
             + math.cos(phi) * math.cos(decl) * math.cos(hour_angle))
    zenith = math.acos(max(-1.0, min(1.0, cos_z)))
    azimuth = math.degrees(math.atan2(math.sin(hour_angle), math.cos(hour_angle) * math.sin(phi)
                                      - math.tan(decl) * math.cos(phi))) + 180
    return 90 - math.degrees(zenith), azimuth % 360


def main() -> None:
    path = Path(sys.argv[1]) if len(sys.argv) > 1 else DEFAULT
    frames = []
    for image in json.loads(path.read_text())["images"]:
        m = image.get("meta") or {}
        if "gimbal_heading(degrees)" not in m:
            continue
        when = dt.datetime.strptime(m["datetime(utc)"][:19], "%Y-%m-%d %H:%M:%S")
        elevation, azimuth = solar_position(when, m["latitude"], m["longitude"])
        frames.append((m["height_above_takeoff(meter)"], m["gimbal_pitch(degrees)"],
                       (azimuth - m["gimbal_heading(degrees)"]) % 360, elevation))
    frames.sort(key=lambda f: (f[0], f[1]))
    picked = [frames[int((i + 0.5) * len(frames) / 100)] for i in range(100)]
    pairs = [(round(a), round(p)) for a, p, _, _ in picked]
    if pairs != list(zip(SDS_ALTITUDE, SDS_PITCH, strict=True)):
        raise SystemExit("the picked frames are not the preset's (altitude, pitch) pairs")
    print("SDS_HEADING =", tuple(round(h) % 360 for _, _, h, _ in picked))
    print("SDS_SUN_ELEVATION =", tuple(round(e) for _, _, _, e in picked))


if __name__ == "__main__":
    main()
