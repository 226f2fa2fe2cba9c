"""The simulated GNSS world: what the signals really go through, as opposed to
the broadcast models the receiver removes (STYLE pattern 16: the world is
not the filter's model).

Two worlds, chosen by the scenario's ``world.model`` (:mod:`..world`):

``perfect`` (unit tests): truth = the receiver's own models. Ionosphere =
  broadcast Klobuchar (x ``gnss.raw.ionosphere_truth_scale``), troposphere =
  Hopfield with the standard atmosphere, satellite orbits and clocks = the
  broadcast records. A noise-free receiver then corrects its pseudoranges
  exactly.

``realistic`` (default for flights): independent models with a realistic,
  configurable mismatch.

* Ionosphere (:class:`TrueIonosphere`): thin shell at 350 km with the
  geometric pierce point and the single-layer mapping function
  1 / sqrt(1 - ((R + h_rx) cos E / (R + h_shell))^2), not Klobuchar's own
  pierce-point approximation and obliquity factor 1 + 16 (0.53 - E)^3.
  Vertical delay = the broadcast Klobuchar vertical delay at the pierce
  point x (1 + s g(pierce point, t)), g a unit-variance smooth Gaussian field
  (:class:`..random_field.GaussianField`) over the shell (correlation length
  ``correlation_length_km``, default 1000 km) and time
  (``correlation_time_s``, 1800 s), s = ``klobuchar_error_rms`` (0.5): the
  broadcast model removes about 50 % of the RMS ionospheric delay
  (Klobuchar, "Ionospheric time-delay algorithm for single-frequency GPS
  users", IEEE Trans. AES 23(3), 1987; ESA Navipedia "Klobuchar Ionospheric
  Model": "estimated to reduce about the 50 % RMS ionospheric range error
  worldwide"). The correlation length and time are our choices, of the
  order of the large-scale structure of mid-latitude TEC deviations from a
  climatological model (the paper gives none).
* Troposphere (:class:`TrueTroposphere`): Saastamoinen zenith delays
  (hydrostatic 0.0022768 P / (1 - 0.00266 cos 2 phi - 0.00028 H_km), wet
  0.002277 (1255 / T + 0.05) e; Saastamoinen 1972, Davis et al. 1985) with
  the Niell (1996) hydrostatic (with its height correction) and wet mapping
  functions, under a non-standard meteorology varying in space and time
  (surface pressure, temperature and relative humidity = mean + sigma x
  smooth Gaussian fields, correlation 500 km / 3 h by default). The
  hydrostatic delay above the receiver scales with the pressure at its
  height (US76 profile scaled by the surface pressure); water vapour decays
  with a 2 km scale height. The receiver removes Hopfield with the
  standard atmosphere (1013.25 hPa, 288.15 K, 11.7 hPa).
* Orbits and clocks (:class:`OrbitClockErrors`): true = broadcast minus the
  broadcast error, per satellite in radial / along / cross and clock: a
  constant per satellite plus a smooth time-correlated variation, with the
  sizes and correlation times measured on the real broadcast and precise
  files of ``../shared/gnss-real`` (:mod:`.broadcast_error`, table
  :data:`ORBIT_CLOCK_ERRORS`).
"""
from __future__ import annotations

import datetime as _dt
from dataclasses import dataclass

import numpy as np

from hyper_nav_gnss import earth
from hyper_nav_gnss.corrections.propagation import hopfield_delay_m, klobuchar_delay_m

from hyper_nav_filter.core.atmosphere import pressure_Pa
from ..random_field import GaussianField
from .broadcast_error import rac_frame, satellite_class

R_EARTH_M = 6371e3
_GPS_EPOCH = _dt.datetime(1980, 1, 6)


# ---------------------------------------------------------------------------------------------- ionosphere
class KlobucharIonosphere:
    """Perfect-model ionosphere: the broadcast Klobuchar delay (x ``scale``)."""

    def __init__(self, coefficients: dict, scale: float = 1.0):
        self.coefficients = coefficients          # {system: (alpha, beta)}
        self.scale = float(scale)

    def slant_delay_m(self, system, lat_rad, lon_rad, alt_m, el_rad, az_rad, t_gpst_s, freq_hz):
        if system not in self.coefficients:
            return np.zeros(np.shape(el_rad))
        a, b = self.coefficients[system]
        return self.scale * klobuchar_delay_m(a, b, lat_rad, lon_rad, np.maximum(el_rad, 0.0), az_rad, t_gpst_s,
                                              freq_hz)


def pierce_point(lat_rad, lon_rad, alt_m, el_rad, az_rad, shell_height_m):
    """Geometric pierce point (lat, lon) of the ray at the thin shell and the
    single-layer mapping function 1/cos(z'), receiver at height alt_m."""
    el = np.asarray(el_rad, float)
    s = (R_EARTH_M + alt_m) / (R_EARTH_M + shell_height_m) * np.cos(el)
    zp = np.arcsin(np.clip(s, -1.0, 1.0))
    psi = np.pi / 2.0 - el - zp                                   # Earth-centred angle
    lat_i = np.arcsin(np.sin(lat_rad) * np.cos(psi) + np.cos(lat_rad) * np.sin(psi) * np.cos(az_rad))
    lon_i = lon_rad + np.arcsin(np.clip(np.sin(psi) * np.sin(az_rad) / np.cos(lat_i), -1.0, 1.0))
    return lat_i, lon_i, 1.0 / np.cos(zp)


class TrueIonosphere:
    """Realistic ionosphere (module docstring): Klobuchar's vertical delay at
    the geometric pierce point x (1 + s g), single-layer mapping."""

    def __init__(self, coefficients: dict, rng: np.random.Generator, klobuchar_error_rms: float = 0.5,
                 correlation_length_km: float = 1000.0, correlation_time_s: float = 1800.0,
                 shell_height_km: float = 350.0, min_factor: float = 0.1):
        self.coefficients = coefficients
        self.rel = float(klobuchar_error_rms)
        self.shell_m = float(shell_height_km) * 1e3
        self.min_factor = float(min_factor)
        L = float(correlation_length_km) * 1e3
        self._scale = np.array([L, L, L, float(correlation_time_s)])
        self.field = GaussianField(np.ones(4), rng)

    def relative_error(self, lat_ipp_rad, lon_ipp_rad, t_gpst_s):
        """s g at pierce points (truth / Klobuchar vertical - 1, before clipping)."""
        r = np.atleast_2d(earth.geodetic_to_ecef(lat_ipp_rad, lon_ipp_rad, self.shell_m))
        t = np.broadcast_to(np.asarray(t_gpst_s, float), r.shape[:-1])
        x = np.concatenate([r, t[..., None]], axis=-1) / self._scale
        return self.rel * self.field(x)[..., 0]

    def slant_delay_m(self, system, lat_rad, lon_rad, alt_m, el_rad, az_rad, t_gpst_s, freq_hz):
        el = np.atleast_1d(np.asarray(el_rad, float))
        if system not in self.coefficients:
            return np.zeros(el.shape)
        a, b = self.coefficients[system]
        lat_i, lon_i, mapping = pierce_point(lat_rad, lon_rad, alt_m, el, az_rad, self.shell_m)
        half_pi = np.full(el.shape, np.pi / 2.0)
        # Klobuchar vertical delay at the pierce point (its obliquity factor at 90 deg is 1.0004)
        vert = klobuchar_delay_m(a, b, lat_i, lon_i, half_pi, 0.0, t_gpst_s, freq_hz) / (1.0 + 16.0 * 0.03 ** 3)
        factor = np.maximum(1.0 + self.relative_error(lat_i, lon_i, t_gpst_s), self.min_factor)
        return vert * factor * mapping


# --------------------------------------------------------------------------------------------- troposphere
class HopfieldTroposphere:
    """Perfect-model troposphere: the receiver's Hopfield, standard atmosphere."""

    def slant_delay_m(self, lat_rad, lon_rad, alt_m, el_rad, t_gpst_s):
        return hopfield_delay_m(np.maximum(el_rad, 0.0), alt_m)[0]


# Niell (1996) mapping-function coefficients at latitudes 15, 30, 45, 60, 75 deg
# (J. Geophys. Res. 101(B2) 3227-3246, Tables 3 and 4; the same numbers as RTKLIB's tropmapf)
NIELL_LAT_DEG = np.array([15.0, 30.0, 45.0, 60.0, 75.0])
NIELL_HYD_AVG = np.array([[1.2769934e-3, 1.2683230e-3, 1.2465397e-3, 1.2196049e-3, 1.2045996e-3],
                          [2.9153695e-3, 2.9152299e-3, 2.9288445e-3, 2.9022565e-3, 2.9024912e-3],
                          [62.610505e-3, 62.837393e-3, 63.721774e-3, 63.824265e-3, 64.258455e-3]])
NIELL_HYD_AMP = np.array([[0.0, 1.2709626e-5, 2.6523662e-5, 3.4000452e-5, 4.1202191e-5],
                          [0.0, 2.1414979e-5, 3.0160779e-5, 7.2562722e-5, 11.723375e-5],
                          [0.0, 9.0128400e-5, 4.3497037e-5, 84.795348e-5, 170.37206e-5]])
NIELL_HEIGHT = (2.53e-5, 5.49e-3, 1.14e-3)
NIELL_WET = np.array([[5.8021897e-4, 5.6794847e-4, 5.8118019e-4, 5.9727542e-4, 6.1641693e-4],
                      [1.4275268e-3, 1.5138625e-3, 1.4572752e-3, 1.5007428e-3, 1.7599082e-3],
                      [4.3472961e-2, 4.6729510e-2, 4.3908931e-2, 4.4626982e-2, 5.4736038e-2]])


def _continued_fraction(sin_el, a, b, c):
    return (1.0 + a / (1.0 + b / (1.0 + c))) / (sin_el + a / (sin_el + b / (sin_el + c)))


def niell_mapping(el_rad, lat_rad, h_m, day_of_year):
    """Niell (1996) hydrostatic and wet mapping functions (arrays like el)."""
    lat_deg = abs(np.rad2deg(float(lat_rad)))
    interp = lambda row: np.interp(lat_deg, NIELL_LAT_DEG, row)       # noqa: E731 (clamped outside 15-75)
    doy = day_of_year + (182.625 if lat_rad < 0 else 0.0)            # southern hemisphere: half a year later
    cs = np.cos(2.0 * np.pi * (doy - 28.0) / 365.25)
    ah, bh, ch = (interp(NIELL_HYD_AVG[i]) - interp(NIELL_HYD_AMP[i]) * cs for i in range(3))
    s = np.sin(np.maximum(np.asarray(el_rad, float), np.deg2rad(1.0)))
    m_h = _continued_fraction(s, ah, bh, ch) + (1.0 / s - _continued_fraction(s, *NIELL_HEIGHT)) * h_m * 1e-3
    m_w = _continued_fraction(s, *(interp(NIELL_WET[i]) for i in range(3)))
    return m_h, m_w


def saturation_vapour_pressure_hpa(t_k):
    """Magnus formula over water (Alduchov & Eskridge 1996) [hPa]."""
    tc = np.asarray(t_k, float) - 273.15
    return 6.1094 * np.exp(17.625 * tc / (tc + 243.04))


class TrueTroposphere:
    """Realistic troposphere (module docstring): Saastamoinen + Niell under a
    meteorology that varies in space and time."""

    def __init__(self, rng: np.random.Generator, surface_pressure_hpa=1013.25, surface_pressure_sigma_hpa=8.0,
                 surface_temperature_k=288.15, surface_temperature_sigma_k=8.0, relative_humidity=0.6,
                 relative_humidity_sigma=0.2, correlation_length_km=500.0, correlation_time_s=10800.0,
                 water_vapour_scale_height_m=2000.0):
        self.p0, self.sp = float(surface_pressure_hpa), float(surface_pressure_sigma_hpa)
        self.t0, self.st = float(surface_temperature_k), float(surface_temperature_sigma_k)
        self.rh0, self.srh = float(relative_humidity), float(relative_humidity_sigma)
        self.h_w = float(water_vapour_scale_height_m)
        L = float(correlation_length_km) * 1e3
        self._scale = np.array([L, L, L, float(correlation_time_s)])
        self.field = GaussianField(np.ones(4), rng, n_fields=3)
        self._p_ref = float(pressure_Pa(0.0))

    def meteorology(self, lat_rad, lon_rad, t_gpst_s):
        """Surface pressure [hPa], temperature [K], relative humidity [0-1] below the receiver."""
        r = np.asarray(earth.geodetic_to_ecef(lat_rad, lon_rad, 0.0), float)
        g = self.field(np.r_[r, float(t_gpst_s)] / self._scale)
        return (self.p0 + self.sp * g[0], self.t0 + self.st * g[1],
                float(np.clip(self.rh0 + self.srh * g[2], 0.02, 1.0)))

    def zenith_delays_m(self, lat_rad, lon_rad, alt_m, t_gpst_s):
        """(hydrostatic, wet) zenith delays above the receiver [m]."""
        p_s, t_s, rh = self.meteorology(lat_rad, lon_rad, t_gpst_s)
        h = max(float(alt_m), 0.0)
        p_h = p_s * float(pressure_Pa(h)) / self._p_ref             # hPa at the receiver
        zhd = 0.0022768 * p_h / (1.0 - 0.00266 * np.cos(2.0 * lat_rad) - 0.00028 * h * 1e-3)
        t_h = max(t_s - 0.0065 * min(h, 11000.0), 200.0)
        e_h = rh * saturation_vapour_pressure_hpa(t_s) * np.exp(-h / self.h_w)
        zwd = 0.002277 * (1255.0 / t_h + 0.05) * e_h
        return zhd, zwd

    def slant_delay_m(self, lat_rad, lon_rad, alt_m, el_rad, t_gpst_s):
        zhd, zwd = self.zenith_delays_m(lat_rad, lon_rad, alt_m, t_gpst_s)
        doy = (_GPS_EPOCH + _dt.timedelta(seconds=float(t_gpst_s))).timetuple().tm_yday
        m_h, m_w = niell_mapping(el_rad, lat_rad, max(float(alt_m), 0.0), doy)
        return zhd * m_h + zwd * m_w


# ------------------------------------------------------------------------------------- orbits and clocks
@dataclass(frozen=True)
class BroadcastErrorClass:
    """Broadcast - true of one satellite class: per-satellite constant (RMS over
    satellites) and smooth variation (RMS, correlation time) in radial, along,
    cross [m] and clock [m]. ``bias_rac_m[0]`` is the radial phase-centre
    offset (applied only with ``include_phase_centre_offset``)."""
    bias_rac_m: tuple
    variation_rac_m: tuple
    tau_rac_s: tuple
    bias_clk_m: float
    variation_clk_m: float
    tau_clk_s: float


# Measured with broadcast_error.class_statistics on ../shared/gnss-real (broadcast - precise,
# clocks with the per-epoch system mean removed): GPS = RMS of the 2021-04-28 18-24 h (CODE final)
# and 2023-01-01 00-02 h (GFZ rapid) figures, BDS = 2023-01-01 00-02 h. Per-satellite constant /
# variation about it / correlation time (tau = sigma x 300 s / RMS change over 300 s):
#   GPS  2021: bias RAC [1.20 1.02 0.25] clk 0.50, var [0.12 0.56 0.29] clk 0.12, tau [1669 2519 4846] clk 827
#   GPS  2023: bias RAC [1.20 0.79 0.53] clk 0.53, var [0.08 0.24 0.13] clk 0.08, tau [1769 1527 2074] clk 489
#   MEO  2023: bias RAC [1.17 0.39 0.28] clk 0.63, var [0.03 0.09 0.06] clk 0.23, tau [2045 2221 2088] clk 4800
#   IGSO 2023: bias RAC [1.68 2.89 1.66] clk 0.75, var [0.06 0.14 0.15] clk 0.30, tau [2445 2022 2140] clk 2594
#   GEO  2023: bias RAC [1.67 12.57 0.60] clk 1.91, var [0.11 0.17 0.08] clk 0.14, tau [2182 3951 3895] clk 2148
# 3D RMS as measured (incl. the radial constant): GPS 1.72 / 1.56, MEO 1.27, IGSO 3.74, GEO 12.7 m.
# The radial constant is every satellite's antenna phase-centre offset (broadcast orbits refer to
# the antenna, SP3 to the centre of mass): -0.6 .. -2.3 m, negative for all 105 satellites and
# grouped by satellite block; a receiver using broadcast orbits *and* clocks never sees it, so it
# is left out unless include_phase_centre_offset (then 3D RMS = the raw figures above).
ORBIT_CLOCK_ERRORS = {
    "GPS": BroadcastErrorClass((1.20, 0.92, 0.42), (0.10, 0.43, 0.22), (1700.0, 2000.0, 3000.0), 0.51, 0.10, 650.0),
    "BDS_MEO": BroadcastErrorClass((1.17, 0.39, 0.28), (0.033, 0.092, 0.055), (2000.0, 2200.0, 2100.0),
                                   0.63, 0.23, 4800.0),
    "BDS_IGSO": BroadcastErrorClass((1.68, 2.89, 1.66), (0.056, 0.14, 0.15), (2400.0, 2000.0, 2100.0),
                                    0.75, 0.30, 2600.0),
    "BDS_GEO": BroadcastErrorClass((1.67, 12.57, 0.60), (0.11, 0.17, 0.078), (2200.0, 4000.0, 3900.0),
                                   1.91, 0.14, 2150.0),
}


class NoOrbitClockErrors:
    """Perfect model: the broadcast orbits and clocks are the truth."""

    def true_minus_broadcast(self, eph, t_gpst_s, r_e_m, v_e_mps):
        return np.zeros(3), np.zeros(3), 0.0, 0.0


class OrbitClockErrors:
    """True minus broadcast satellite position/velocity (ECEF) and clock
    (c dt, metres) per satellite: -(constant + smooth variation) in radial /
    along / cross and clock, drawn per satellite from ``seed`` (the same
    satellite gets the same errors whatever the call order)."""

    def __init__(self, seed: int, scale: float = 1.0, include_phase_centre_offset: bool = False,
                 classes: dict | None = None):
        self.seed = int(seed)
        self.scale = float(scale)
        self.pco = bool(include_phase_centre_offset)
        self.classes = ORBIT_CLOCK_ERRORS if classes is None else classes
        self._sat: dict[str, tuple] = {}

    def _satellite(self, eph):
        sid = eph.sat_id
        if sid not in self._sat:
            c = self.classes[satellite_class(sid)]
            rng = np.random.default_rng([self.seed, ord(eph.system), int(eph.prn)])
            bias = np.r_[rng.standard_normal(3) * c.bias_rac_m, rng.standard_normal() * c.bias_clk_m]
            bias[0] = -c.bias_rac_m[0] if self.pco else 0.0        # broadcast APC below the centre of mass
            sig = np.r_[c.variation_rac_m, c.variation_clk_m]
            taus = np.array([*c.tau_rac_s, c.tau_clk_s])[:, None]
            self._sat[sid] = (self.scale * bias, self.scale * sig, GaussianField(taus, rng, n_fields=4))
        return self._sat[sid]

    def broadcast_error(self, eph, t_gpst_s):
        """(e [radial, along, cross, clock] [m], de/dt [m/s]) of a satellite at t (broadcast - true)."""
        bias, sig, field = self._satellite(eph)
        val, grad = field.value_and_gradient(np.array([float(t_gpst_s)]))
        return bias + sig * val, sig * grad[:, 0]

    def true_minus_broadcast(self, eph, t_gpst_s, r_e_m, v_e_mps):
        """(dr_e [m], dv_e [m/s], d(c dt_sat) [m], its rate [m/s]) to add to the
        broadcast satellite state/clock at t to get the truth. The RAC frame is
        that of the broadcast orbit (inertial velocity); its rotation
        (~1.5e-4 rad/s x the error: < 2 mm/s on GEO) is left out of dv."""
        e, de = self.broadcast_error(eph, t_gpst_s)
        we = 7.2921151467e-5
        r = np.asarray(r_e_m, float)
        v_i = np.asarray(v_e_mps, float) + we * np.array([-r[1], r[0], 0.0])
        R = rac_frame(r, v_i)
        return -(e[:3] @ R), -(de[:3] @ R), -e[3], -de[3]


# ------------------------------------------------------------------------------------------------ world
@dataclass
class GnssWorld:
    """What the simulated signals go through (see the module docstring)."""
    ionosphere: object | None         # None: no ionosphere (gnss.raw.ionosphere 'off')
    troposphere: object | None        # None: no troposphere ('off')
    orbits: object
    model: str

    @classmethod
    def perfect(cls, klobuchar: dict | None, troposphere: bool, ionosphere_scale: float = 1.0) -> "GnssWorld":
        return cls(None if klobuchar is None else KlobucharIonosphere(klobuchar, ionosphere_scale),
                   HopfieldTroposphere() if troposphere else None, NoOrbitClockErrors(), "perfect")

    @classmethod
    def realistic(cls, klobuchar: dict | None, troposphere: bool, config, seed: int) -> "GnssWorld":
        """``config``: :class:`..world.WorldConfig`; ``seed`` draws this world's realisation."""
        ss = np.random.SeedSequence([int(seed), 0x9E55])
        r_iono, r_tropo, r_orb = (np.random.default_rng(s) for s in ss.spawn(3))
        iono = None if klobuchar is None else TrueIonosphere(klobuchar, r_iono, **config.ionosphere)
        tropo = TrueTroposphere(r_tropo, **config.troposphere) if troposphere else None
        orb = OrbitClockErrors(int(r_orb.integers(2 ** 31)), **config.orbits)
        return cls(iono, tropo, orb, "realistic")

    def satellite_truth(self, ephs, t_gpst_s, r_s, v_s, clk_m, drift_mps):
        """True satellite states from the broadcast ones (arrays per satellite,
        clock terms c dt in m, m/s)."""
        r, v, c, d = r_s.copy(), v_s.copy(), np.array(clk_m, float), np.array(drift_mps, float)
        for k, e in enumerate(ephs):
            dr, dv, dc, dd = self.orbits.true_minus_broadcast(e, t_gpst_s, r_s[k], v_s[k])
            r[k] += dr
            v[k] += dv
            c[k] += dc
            d[k] += dd
        return r, v, c, d
