"""Signal environment of a body-mounted GNSS antenna on a hypersonic vehicle:
per satellite and epoch carrier-to-noise density C/N0 [dB-Hz] from geometry,
antenna pattern, plasma-sheath attenuation and thermal noise (no multipath).

Link budget (Kaplan & Hegarty 2nd ed. ch. 4 and sec. 5.6;
Groves 2nd ed. sec. 9.1.4 "Signal power and noise"):

    C/N0 [dB-Hz] = P_r(el) [dBW] + G_a(theta) [dBic] - L_sys [dB] - A_plasma [dB]
                   - 10 log10(k T_sys) [dBW/Hz]

* P_r(el): received power at a 0 dBic antenna versus elevation, a table
  (default: -158.5 dBW at the horizon, the IS-GPS-200 minimum for L1 C/A; the
  typical ~2.5 dB rise to mid elevations from the satellite antenna's
  earth-coverage shaping and the shorter path, Kaplan & Hegarty 2nd ed.
  ch. 3-4). Interpolated linearly in elevation [deg].
* G_a(theta): gain of the body-mounted antenna at the off-boresight angle
  theta = acos(b_n . u_n) between the antenna boresight (a body FLU unit
  vector, rotated with the truth attitude C_b_n) and the line of sight in ENU.
  Default table: a typical L1 patch, +3 dBic at boresight, -6 dBic at 90 deg
  (horizon of the antenna plane), -20 dBic back lobe. Hypersonic flight rolls
  and pitches the antenna, so this term moves satellites in and out of view.
* T_sys: system noise temperature [K], default 513 K (sky ~ 100-130 K
  plus a ~2 dB noise-figure front end, Kaplan & Hegarty 2nd ed. ch. 4); L_sys:
  implementation loss [dB].
* A_plasma: plasma-sheath attenuation, :class:`PlasmaSheath` (scenario data:
  a dB-versus-time table, or a cold collisional plasma slab model driven by
  altitude and Mach number).

The thermal noise itself enters in the correlator outputs the tracking
simulation draws (:mod:`.tracking`): unit-variance I/Q noise per accumulation
whose signal amplitude is sqrt(2 T C/N0) (Kaplan & Hegarty 2nd ed. sec. 5.6;
Groves 2nd ed. sec. 9.2).

Angles inside are radians unless a name says ``_deg``; frames: body FLU, ENU.
"""
from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

BOLTZMANN_DBW_PER_K_HZ = -228.6              # 10 log10(1.380649e-23)
from hyper_nav_gnss.constants import C_MPS
EPS0 = 8.8541878128e-12
E_CHARGE_C = 1.602176634e-19
M_E_KG = 9.1093837015e-31


def _finite_table(name, x, y, x_lo=None, x_hi=None):
    x = np.asarray(x, float)
    y = np.asarray(y, float)
    if x.ndim != 1 or x.shape != y.shape or x.size < 2:
        raise ValueError(f"{name}: expected two equal-length lists of at least 2 numbers, got {x!r}, {y!r}")
    if not (np.all(np.isfinite(x)) and np.all(np.isfinite(y))):
        raise ValueError(f"{name}: table holds non-finite values")
    if np.any(np.diff(x) <= 0):
        raise ValueError(f"{name}: abscissae must be strictly increasing, got {x.tolist()}")
    if (x_lo is not None and x[0] > x_lo) or (x_hi is not None and x[-1] < x_hi):
        raise ValueError(f"{name}: table must cover [{x_lo}, {x_hi}], got [{x[0]}, {x[-1]}]")
    return x, y


def los_enu(el_rad, az_rad):
    """Unit line-of-sight vectors receiver->satellite in ENU, shape (..., 3)."""
    el, az = np.asarray(el_rad, float), np.asarray(az_rad, float)
    ce = np.cos(el)
    return np.stack([ce * np.sin(az), ce * np.cos(az), np.sin(el)], axis=-1)


def off_boresight_rad(el_rad, az_rad, C_b_n, boresight_b=(0.0, 0.0, 1.0)):
    """Angle [rad] between the antenna boresight (body FLU unit vector, rotated to
    ENU by C_b_n (3,3) or per satellite (N,3,3)) and each line of sight."""
    b = np.asarray(boresight_b, float)
    b = b / np.linalg.norm(b)
    b_n = np.asarray(C_b_n, float) @ b
    u = los_enu(el_rad, az_rad)
    c = np.clip(np.sum(u * b_n, axis=-1), -1.0, 1.0)
    return np.arccos(c)


@dataclass
class AntennaPattern:
    """Gain [dBic] vs off-boresight angle [deg], interpolated linearly; boresight in body FLU."""
    off_boresight_deg: tuple = (0.0, 30.0, 60.0, 75.0, 90.0, 110.0, 130.0, 180.0)
    gain_dbic: tuple = (3.0, 2.0, -1.0, -3.0, -6.0, -12.0, -18.0, -20.0)
    boresight_b: tuple = (0.0, 0.0, 1.0)

    def __post_init__(self):
        self._x, self._y = _finite_table("antenna.gain_dbic", self.off_boresight_deg, self.gain_dbic, 0.0, 180.0)
        b = np.asarray(self.boresight_b, float)
        if b.shape != (3,) or not np.all(np.isfinite(b)) or np.linalg.norm(b) == 0:
            raise ValueError(f"antenna.boresight_b: expected a non-zero 3-vector (body FLU), got {self.boresight_b!r}")

    def gain_dbic_at(self, theta_rad):
        return np.interp(np.rad2deg(theta_rad), self._x, self._y)


def plasma_attenuation_db(ne_m3, collision_hz, thickness_m, carrier_hz):
    """Power attenuation [dB] of a plane wave crossing a uniform cold collisional
    plasma slab (no reflection loss): epsilon_r = 1 - w_p^2 / (w (w - j nu)),
    w_p^2 = n_e e^2 / (eps0 m_e); attenuation = 20 log10(e) (w/c) |Im sqrt(eps_r)| d.
    Below the plasma frequency (w_p > w) the wave is evanescent, the blackout
    (Rybak & Churchill, IEEE TAES 7(5), 1971; Hartunian et al., Aerospace Corp.
    ATR-2007(5309)-1, 2007, sec. 2). For L1 the critical density is
    n_c = eps0 m_e w^2 / e^2 = 3.08e16 m^-3."""
    ne = np.asarray(ne_m3, float)
    w = 2 * np.pi * np.asarray(carrier_hz, float)
    wp2 = ne * E_CHARGE_C ** 2 / (EPS0 * M_E_KG)
    eps = 1.0 - wp2 / (w * (w - 1j * np.asarray(collision_hz, float)))
    alpha_np_per_m = (w / C_MPS) * np.abs(np.imag(np.sqrt(eps)))
    return 20.0 * np.log10(np.e) * alpha_np_per_m * np.asarray(thickness_m, float)


@dataclass
class PlasmaSheath:
    """Plasma-sheath attenuation [dB] on the antenna (all satellites alike).

    ``mode='table'``: attenuation ``att_db`` versus scenario time ``t_s`` (linear
    interpolation, 0 dB outside) -- the scenario's blackout profile as data.

    ``mode='model'``: electron density of the shock layer over the antenna from
    an empirical law in Mach number M and air density rho (US 1976),
        n_e = ne_ref_m3 * (rho / rho_ref)^rho_exp * 10^(decades_per_mach (M - mach_ref)),
    collision frequency nu = collision_ref_hz * rho / rho_ref, through a slab of
    ``thickness_m`` (:func:`plasma_attenuation_db`), capped at ``max_db``. The
    steep rise of ionisation with flight speed and its scaling with density are
    the trends of the RAM-C reentry measurements (Grantham, NASA TN D-6062,
    1970; Hartunian et al. 2007, Fig. 3); the default coefficients are
    illustrative (critical L1 density at Mach 12 and 40 km), not a fit: a
    scenario for a specific vehicle must set its own.
    ``mode='off'``: 0 dB."""
    mode: str = "off"
    t_s: tuple = ()
    att_db: tuple = ()
    ne_ref_m3: float = 3.0e16
    rho_ref_kgpm3: float = 3.996e-3          # US 1976 at 40 km
    rho_exp: float = 0.5
    mach_ref: float = 12.0
    decades_per_mach: float = 0.5
    collision_ref_hz: float = 1.0e9
    thickness_m: float = 0.05
    max_db: float = 80.0

    def __post_init__(self):
        if self.mode not in ("off", "table", "model"):
            raise ValueError(f"plasma.mode: expected 'off', 'table' or 'model', got {self.mode!r}")
        if self.mode == "table":
            self._t, self._a = _finite_table("plasma.att_db", self.t_s, self.att_db)
            if np.any(self._a < 0):
                raise ValueError("plasma.att_db: attenuation must be >= 0 dB")
        for k in ("ne_ref_m3", "rho_ref_kgpm3", "thickness_m", "max_db"):
            v = getattr(self, k)
            if not np.isfinite(v) or v <= 0:
                raise ValueError(f"plasma.{k}: expected a finite number > 0, got {v!r}")

    def attenuation_db(self, t_s, alt_m=None, mach=None, carrier_hz=1575.42e6):
        t = np.asarray(t_s, float)
        if self.mode == "off":
            return np.zeros_like(t)
        if self.mode == "table":
            return np.interp(t, self._t, self._a, left=0.0, right=0.0)
        from hyper_nav_filter.core import atmosphere
        if alt_m is None or mach is None:
            raise ValueError("plasma.mode 'model' needs alt_m and mach")
        rho = atmosphere.density_kgpm3(np.asarray(alt_m, float)) / self.rho_ref_kgpm3
        ne = self.ne_ref_m3 * rho ** self.rho_exp * 10.0 ** (self.decades_per_mach * (np.asarray(mach) - self.mach_ref))
        a = plasma_attenuation_db(ne, self.collision_ref_hz * rho, self.thickness_m, carrier_hz)
        return np.minimum(a, self.max_db)


@dataclass
class SignalEnvironment:
    """C/N0 per satellite and epoch (module docstring). Fields in the units of their names."""
    power_el_deg: tuple = (0.0, 10.0, 40.0, 90.0)
    power_dbw: tuple = (-158.5, -157.5, -156.0, -157.0)
    t_sys_k: float = 513.0
    implementation_loss_db: float = 1.0
    antenna: AntennaPattern = field(default_factory=AntennaPattern)
    plasma: PlasmaSheath = field(default_factory=PlasmaSheath)

    def __post_init__(self):
        self._pe, self._pp = _finite_table("signal.power_dbw", self.power_el_deg, self.power_dbw, 0.0, 90.0)
        if not np.isfinite(self.t_sys_k) or self.t_sys_k <= 0:
            raise ValueError(f"signal.t_sys_k: expected > 0 K, got {self.t_sys_k!r}")

    @property
    def n0_dbw_per_hz(self) -> float:
        return BOLTZMANN_DBW_PER_K_HZ + 10.0 * np.log10(self.t_sys_k)

    @classmethod
    def from_dict(cls, d: dict | None) -> "SignalEnvironment":
        d = dict(d or {})
        allowed = {"power_el_deg", "power_dbw", "t_sys_k", "implementation_loss_db", "antenna", "plasma"}
        bad = set(d) - allowed
        if bad:
            raise ValueError(f"signal: unknown field(s) {sorted(bad)}; allowed {sorted(allowed)}")
        ant = d.pop("antenna", None) or {}
        pl = d.pop("plasma", None) or {}
        if not isinstance(ant, dict) or not isinstance(pl, dict):
            raise ValueError("signal.antenna and signal.plasma must be mappings")
        try:
            ant_o = AntennaPattern(**{k: tuple(v) if isinstance(v, list) else v for k, v in ant.items()})
            pl_o = PlasmaSheath(**{k: tuple(v) if isinstance(v, list) else v for k, v in pl.items()})
            return cls(antenna=ant_o, plasma=pl_o, **{k: tuple(v) if isinstance(v, list) else v for k, v in d.items()})
        except TypeError as e:
            raise ValueError(f"signal: {e}") from None

    def cn0_dbhz(self, t_s, el_rad, az_rad, C_b_n, alt_m=None, mach=None, carrier_hz=1575.42e6):
        """C/N0 [dB-Hz] of the satellites at (el_rad, az_rad) (N,) seen at time t_s
        with body attitude C_b_n (3,3)."""
        el = np.asarray(el_rad, float)
        p = np.interp(np.rad2deg(np.clip(el, 0.0, np.pi / 2)), self._pe, self._pp)
        g = self.antenna.gain_dbic_at(off_boresight_rad(el, az_rad, C_b_n, self.antenna.boresight_b))
        a = self.plasma.attenuation_db(t_s, alt_m, mach, carrier_hz)
        return p + g - self.implementation_loss_db - a - self.n0_dbw_per_hz


__all__ = ["SignalEnvironment", "AntennaPattern", "PlasmaSheath", "plasma_attenuation_db", "off_boresight_rad",
           "los_enu"]
