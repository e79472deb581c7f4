"""sRGB colour sets shared by the kinds (0-255 tuples; albedo-like, before lighting)."""

from __future__ import annotations

import numpy as np

RGB = tuple[int, int, int]

# Monk Skin Tone scale, MST-1 .. MST-10 (Ellis Monk 2019; Google's published swatches
# f6ede4 f3e7db f7ead0 eadaba d7bd96 a07e56 825c43 604134 3a312a 292420). Swatches are display
# colours of lit skin; :func:`skin` scales them to an albedo and warms the light ones a little
# (wet skin in sunlight reads slightly pinker/darker than the swatch).
SKIN_MONK: tuple[RGB, ...] = (
    (246, 237, 228), (243, 231, 219), (247, 234, 208), (234, 218, 186), (215, 189, 150),
    (160, 126, 86), (130, 92, 67), (96, 65, 52), (58, 49, 42), (41, 36, 32),
)


def skin(index: int) -> RGB:
    """Albedo for Monk tone ``index`` (0-based): the swatch x (0.86, 0.80, 0.76)."""
    r, g, b = SKIN_MONK[index]
    return (round(r * 0.86), round(g * 0.80), round(b * 0.76))


HAIR: tuple[RGB, ...] = (
    (28, 24, 22), (45, 33, 26), (70, 48, 32), (105, 75, 48), (150, 115, 70), (185, 155, 105),
    (120, 60, 30), (140, 138, 132),
)


#: how often each :data:`HAIR` colour is drawn for people in the water (relative weights):
#: mostly dark (black and dark brown), fewer light (blond, red, grey), as in Europe's
#: population, where the public SAR footage is flown
HAIR_SHARE: tuple[float, ...] = (0.22, 0.22, 0.18, 0.14, 0.08, 0.06, 0.05, 0.05)
#: diffuse reflectance factor of wet hair (linear light): the water film between the fibres
#: cuts their multiple scattering, so wet hair looks about half as bright as dry
WET_HAIR = 0.45


def draw_hair(rng: np.random.Generator) -> RGB:
    """One :data:`HAIR` colour drawn with the weights of :data:`HAIR_SHARE` (dry)."""
    p = np.asarray(HAIR_SHARE) / sum(HAIR_SHARE)
    return HAIR[int(rng.choice(len(HAIR), p=p))]


def darken(rgb, factor: float) -> RGB:
    """``rgb`` (sRGB 0-255) with its diffuse reflectance times ``factor`` (in linear light,
    gamma 2.2), rounded and clipped."""
    lin = (np.asarray(rgb, float) / 255.0) ** 2.2 * factor
    r, g, b = (int(v) for v in np.clip(np.rint(255.0 * lin ** (1 / 2.2)), 0, 255))
    return r, g, b


def wet_hair(rgb: RGB) -> RGB:
    """``rgb`` (sRGB 0-255) as wet hair: :data:`WET_HAIR` x the dry colour in linear light."""
    return darken(rgb, WET_HAIR)


SWIM_CAPS: tuple[RGB, ...] = (
    (235, 235, 230), (210, 30, 35), (245, 200, 20), (245, 110, 20), (30, 80, 190),
    (230, 90, 160), (25, 25, 28), (170, 172, 175), (40, 160, 70),
)
SWIMWEAR: tuple[RGB, ...] = (
    (200, 30, 40), (25, 35, 80), (25, 25, 28), (30, 90, 180), (30, 140, 70), (240, 120, 30),
    (230, 80, 150), (240, 220, 40), (235, 235, 230), (90, 40, 120),
)
# wetsuits: black neoprene nearly always (a dark navy or charcoal now and then)
WETSUIT: tuple[RGB, ...] = ((22, 22, 25), (22, 22, 25), (22, 22, 25), (20, 24, 30),
                            (25, 32, 55), (48, 50, 54))
SHIRTS: tuple[RGB, ...] = (
    (235, 235, 230), (200, 35, 40), (35, 70, 150), (240, 200, 40), (40, 120, 60),
    (120, 120, 120), (30, 30, 32), (240, 130, 40), (150, 40, 90),
)
TROUSERS: tuple[RGB, ...] = ((55, 70, 100), (40, 50, 75), (150, 135, 100), (30, 30, 32),
                             (90, 90, 85))
SHOES: tuple[RGB, ...] = ((235, 235, 230), (30, 30, 32), (90, 60, 40), (40, 60, 120))
VESTS: tuple[RGB, ...] = ((245, 100, 20), (245, 100, 20), (240, 195, 20), (205, 30, 30))
#: lifeguards' rescue tubes: red most, orange, yellow
RESCUE_TUBES: tuple[RGB, ...] = ((205, 30, 30), (205, 30, 30), (245, 100, 20), (240, 195, 20))

# Boats and personal watercraft
# hulls: white gelcoat on three in four leisure boats (off-white and light grey among them:
# "the vast majority of boats are white", builders mould coloured hulls at extra cost and
# light grey "holds up better"), the rest navy, black, red, blue or green
HULLS: tuple[RGB, ...] = (
    *((238, 238, 232),) * 10, (225, 225, 215), (225, 225, 215), (232, 230, 222),
    (232, 230, 222), (200, 200, 195), (30, 45, 85), (35, 35, 38), (165, 30, 35),
    (40, 95, 160), (20, 90, 80),
)
ANTIFOULING: tuple[RGB, ...] = ((35, 35, 38), (150, 35, 30), (30, 45, 90), (235, 235, 230))
DECKS: tuple[RGB, ...] = ((232, 232, 226), (225, 220, 205), (200, 195, 185), (150, 110, 70))
TEAK = (150, 105, 60)
WOOD = (160, 115, 70)
SEAT_CUSHIONS: tuple[RGB, ...] = ((225, 222, 210), (40, 40, 42), (30, 60, 110),
                                  (150, 40, 40))
CANVAS: tuple[RGB, ...] = ((40, 60, 110), (30, 30, 32), (200, 200, 195), (120, 110, 95),
                           (160, 40, 40))
GLASS = (45, 60, 70)
ENGINE: tuple[RGB, ...] = ((35, 35, 38), (230, 230, 228), (130, 135, 140), (30, 40, 80))
SAIL = (235, 232, 222)
MAST = (190, 192, 195)
RIB_TUBES: tuple[RGB, ...] = ((85, 88, 92), (245, 100, 20), (40, 40, 44), (200, 35, 35),
                              (130, 132, 135))
KAYAKS: tuple[RGB, ...] = (
    (245, 200, 20), (235, 80, 25), (210, 30, 40), (30, 110, 190), (40, 150, 70),
    (235, 235, 230), (120, 200, 60), (40, 170, 170),
)
PWC: tuple[RGB, ...] = (
    (235, 235, 232), (245, 200, 20), (30, 30, 34), (30, 80, 170), (200, 30, 35),
    (140, 200, 40), (240, 110, 30), (90, 90, 95), (20, 140, 150),
)
PWC_TRIM: tuple[RGB, ...] = ((30, 30, 34), (90, 90, 95), (235, 235, 232), (245, 200, 20),
                             (30, 80, 170))
#: a jet ski's deck and hull seen from above, variant ``v``'s the ``v``-th (a cycle, so
#: the eight hold the mix exactly): white on five (Sea-Doo, Yamaha), light grey on two,
#: black on one (Kawasaki, performance models): 17 of 20 jet skis in the aerial-maritime
#: lake photos are white or light grey from above (three in eight were dark before)
PWC_DECK: tuple[RGB, ...] = ((236, 236, 232), (205, 207, 208), (236, 236, 232), (236, 236, 232),
                             (236, 236, 232), (32, 32, 35), (236, 236, 232), (205, 207, 208))
#: its one bright accent (hood, pod, side panels): variant ``v`` takes entry ``v`` (mod 8),
#: so that the eight variants show the makers' colours as often as the market does, blue
#: the most (two), then teal, lime, yellow, red, black and grey (a draw of eight from
#: these gave three red or orange)
PWC_ACCENT: tuple[RGB, ...] = (
    (30, 80, 170), (140, 200, 40), (20, 140, 150), (32, 32, 35), (30, 80, 170),
    (120, 122, 126), (240, 200, 20), (200, 30, 35),
)
PWC_SEAT: tuple[RGB, ...] = ((28, 28, 30), (28, 28, 30), (28, 28, 30), (55, 57, 60),
                             (130, 132, 136))
BLACK = (28, 28, 30)
DARK_GREY = (55, 57, 60)
STEEL = (120, 122, 126)
WHITE = (238, 238, 234)

# Life-saving appliances and buoys
ORANGE = (245, 100, 20)  # international orange
RED = (205, 30, 30)
YELLOW = (240, 200, 20)
GREEN = (20, 130, 60)
REFLECTIVE = (215, 218, 222)  # SOLAS retro-reflective tape seen in daylight
ROPE: tuple[RGB, ...] = ((235, 235, 225), (240, 200, 30), (40, 40, 44), (220, 70, 30))
