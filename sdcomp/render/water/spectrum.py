"""Sea-surface slope statistics: the wind-wave spectrum, Cox-Munk slopes, whitecaps.

Units: metres, seconds, radians; wavenumbers ``k`` in rad/m, wavelengths ``2 pi / k`` in m.
Slopes are dimensionless (dz/dx). "Upwind" (u) is along the wind, "crosswind" (c) across it.

- :func:`curvature_spectrum` is the unified directional spectrum of Elfouhaily et al. (1997):
  JONSWAP for the long (gravity) waves, with its peak set by the wind speed and the inverse
  wave age (fetch), plus a gravity-capillary range; its spreading function gives upwind and
  crosswind slopes.
- :func:`cox_munk` gives the total slope variances of Cox & Munk (1954) for a clean (or
  slick-covered) sea. They are the reference for glitter: the spectrum only decides how the
  total is shared between the wave scales a camera resolves and those it cannot.
- Wave scales come in octave *bands*: band ``b`` holds wavelengths in
  ``[BAND0 * 2**b, BAND0 * 2**(b + 1))`` metres (:func:`band_slope_variance`).
"""

from __future__ import annotations

import math
from functools import lru_cache

import numpy as np

from ...scene.water import GRAVITY

K_M = 370.0  # rad/m: wavenumber of the gravity-capillary phase-speed minimum
C_M = 0.23  # m/s: phase speed at K_M
BAND0 = 0.01  # m: shortest wavelength of band 0
N_BANDS = 16  # bands 0..15: 1 cm .. 655 m
FULLY_DEVELOPED = 0.84  # inverse wave age of a fully developed sea


def phase_speed(k):
    """Phase speed (m/s) of gravity-capillary waves of wavenumber ``k`` (rad/m), deep water."""
    k = np.asarray(k, np.float64)
    return np.sqrt(GRAVITY / k * (1.0 + (k / K_M) ** 2))


def friction_velocity(wind: float) -> float:
    """Friction velocity u* (m/s) for a 10 m wind of ``wind`` m/s (drag coefficient
    ``(0.8 + 0.065 U) 1e-3``, Wu 1982, as used by Elfouhaily et al. 1997)."""
    u = max(float(wind), 0.1)
    return math.sqrt((0.8 + 0.065 * u) * 1e-3) * u


def curvature_spectrum(k, wind: float, omega: float = FULLY_DEVELOPED):
    """Omnidirectional curvature spectrum ``B(k) = k**3 S(k)`` (dimensionless) of Elfouhaily et
    al. (1997) for a 10 m wind of ``wind`` m/s and inverse wave age ``omega`` (0.84: fully
    developed open sea; 1-5: younger, fetch-limited waves of lakes and coasts).

    The slope variance in a range of wavenumbers is the integral of ``B`` over ``ln k``.
    """
    k = np.asarray(k, np.float64)
    u = max(float(wind), 0.1)
    om = min(max(float(omega), FULLY_DEVELOPED), 5.0)
    ustar = friction_velocity(u)
    k0 = GRAVITY / u ** 2
    kp = k0 * om ** 2
    cp = float(phase_speed(kp))
    c = phase_speed(k)
    # JONSWAP peak enhancement
    gamma = 1.7 if om < 1.0 else 1.7 + 6.0 * math.log10(om)
    sig = 0.08 * (1.0 + 4.0 * om ** -3)
    big_gamma = np.exp(-((np.sqrt(k / kp) - 1.0) ** 2) / (2.0 * sig ** 2))
    lpm = np.exp(-1.25 * (kp / k) ** 2)
    jp = gamma ** big_gamma
    alpha_p = 6e-3 * math.sqrt(om)
    fp = lpm * jp * np.exp(-om / math.sqrt(10.0) * (np.sqrt(k / kp) - 1.0))
    b_long = 0.5 * alpha_p * (cp / c) * fp
    if ustar <= C_M:
        alpha_m = 0.01 * (1.0 + math.log(ustar / C_M))
    else:
        alpha_m = 0.01 * (1.0 + 3.0 * math.log(ustar / C_M))
    alpha_m = max(alpha_m, 1e-4)
    fm = lpm * jp * np.exp(-0.25 * (k / K_M - 1.0) ** 2)
    b_short = 0.5 * alpha_m * (C_M / c) * fm
    return b_long + b_short


def spreading_delta(k, wind: float, omega: float = FULLY_DEVELOPED):
    """Elfouhaily et al. (1997) spreading: the directional spectrum is
    ``S(k) (1 + delta(k) cos 2 phi) / (2 pi)``, phi from the wind direction."""
    k = np.asarray(k, np.float64)
    u = max(float(wind), 0.1)
    om = min(max(float(omega), FULLY_DEVELOPED), 5.0)
    ustar = friction_velocity(u)
    cp = float(phase_speed(GRAVITY / u ** 2 * om ** 2))
    c = phase_speed(k)
    a0 = math.log(2.0) / 4.0
    am = 0.13 * ustar / C_M
    return np.tanh(a0 + 4.0 * (c / cp) ** 2.5 + am * (C_M / c) ** 2.5)


@lru_cache(maxsize=4096)
def _band_variances(wind_q: int, omega_q: int) -> tuple[np.ndarray, np.ndarray]:
    wind, omega = wind_q / 100.0, omega_q / 100.0
    # rows: band -1 (everything from 1 mm to 1 cm), then bands 0 .. N_BANDS - 1; 33
    # log-spaced wavenumbers from each band's longest to its shortest wave
    lam_hi = np.concatenate([[BAND0], BAND0 * 2.0 ** (np.arange(N_BANDS) + 1)])
    lam_lo = np.concatenate([[0.001], BAND0 * 2.0 ** np.arange(N_BANDS)])
    t = np.linspace(0.0, 1.0, 33)[None, :]
    lnk = np.log(2 * math.pi / lam_hi)[:, None] * (1 - t) + np.log(2 * math.pi / lam_lo)[
        :, None] * t
    k = np.exp(lnk)
    bk = curvature_spectrum(k, wind, omega)
    d = spreading_delta(k, wind, omega)
    u = np.trapezoid(bk * 0.5 * (1 + 0.5 * d), lnk, axis=1)
    c = np.trapezoid(bk * 0.5 * (1 - 0.5 * d), lnk, axis=1)
    return u, c


def band_slope_variance(wind: float, omega: float = FULLY_DEVELOPED
                        ) -> tuple[np.ndarray, np.ndarray]:
    """Upwind and crosswind slope variance of each octave band of the spectrum:
    two (N_BANDS + 1,) float64 arrays; index 0 is everything shorter than 1 cm (1 mm to 1 cm),
    index ``b + 1`` is band ``b`` (wavelengths ``BAND0 * 2**b`` to twice that).

    The upwind part of a band is ``int B(k) (1 + delta/2) / 2 d ln k``, the crosswind part
    ``int B(k) (1 - delta/2) / 2 d ln k``; they sum to the band's total slope variance.
    Cached on (wind, omega) rounded to 0.01.
    """
    u, c = _band_variances(int(round(float(wind) * 100)), int(round(float(omega) * 100)))
    return u.copy(), c.copy()


def cox_munk(wind: float, slick: float = 0.0) -> tuple[float, float]:
    """Cox & Munk (1954) upwind and crosswind slope variances for a 12.5 m wind of ``wind``
    m/s: clean sea ``(3.16e-3 U, 0.003 + 1.92e-3 U)``; ``slick`` in [0, 1] blends towards the
    slick-covered sea ``(0.005 + 0.78e-3 U, 0.003 + 0.84e-3 U)``. Their sum is the mean
    square slope (clean: ``0.003 + 5.12e-3 U`` within the fits' rounding)."""
    u = max(float(wind), 0.0)
    s = min(max(float(slick), 0.0), 1.0)
    clean = (3.16e-3 * u, 0.003 + 1.92e-3 * u)
    oily = (0.005 + 0.78e-3 * u, 0.003 + 0.84e-3 * u)
    return ((1 - s) * clean[0] + s * oily[0], (1 - s) * clean[1] + s * oily[1])


def whitecap_fraction(wind: float) -> float:
    """Fraction of the sea covered by whitecaps at a 10 m wind of ``wind`` m/s:
    ``3.84e-6 U**3.41`` (Monahan & O'Muircheartaigh 1980), capped at 0.2."""
    u = max(float(wind), 0.0)
    return min(3.84e-6 * u ** 3.41, 0.2)


def peak_wavelength(wind: float, omega: float = FULLY_DEVELOPED) -> float:
    """Wavelength (m) of the spectral peak: ``2 pi U**2 / (g omega**2)``."""
    u = max(float(wind), 0.1)
    return 2 * math.pi * u ** 2 / (GRAVITY * max(omega, FULLY_DEVELOPED) ** 2)
