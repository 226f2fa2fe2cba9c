"""Pseudorange error budget of a real receiver: what the weights of single-point
positioning and of the filter's pseudorange updates are made of.

Per satellite (variances add, metres):

* receiver noise and multipath, by one of
  - ``elevation``: sigma^2 = a^2 + b^2 / sin^2(el) (RTKLIB manual 2.4.2,
    Appendix E.6 eq. E.6.24, default a = b = 0.3 m for code: its ``err``
    0.003 m x code/phase ratio 100);
  - ``cn0``: sigma^2 = C 10^(-C/N0 / 10) (the C/N0 model of Hartinger and
    Brunner 1999, "Variances of GPS phase observations: the SIGMA-epsilon
    model", GPS Solutions 2(4), applied to code; C = 1.61e4 m^2 Hz gives 0.71 m
    at 45 dB-Hz, 2.3 m at 35 dB-Hz);
  - ``elevation_cn0``: the larger of the two (a low satellite with a strong
    signal keeps its elevation weight, a weak high one its C/N0 weight);
* broadcast orbit and clock: the record's URA / SISA (``accuracy_m``; 0 or
  unknown -> ``ura_default_m``), clipped to [``ura_floor_m``, ...];
* ionosphere: single frequency with Klobuchar, 50 % of the removed delay
  (Klobuchar 1987: the model removes about half the delay in RMS; RTKLIB's
  ERR_BRDCI 0.5); dual-frequency ionosphere-free: 0 (the combination
  amplifies the receiver noise instead, :mod:`.combinations`);
* troposphere: 0.3 m / (sin(el) + 0.1) x 0.1 (RTKLIB ERR_SAAS 0.3 m scaled
  as its ``vartrop``... here 10 % of a 2.4 m zenith delay mapped with
  1 / sin(el)): ``trop_zenith_sigma_m / sin(el)``.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

CN0_CONSTANT_M2HZ = 1.61e4
WEIGHTINGS = ("elevation", "cn0", "elevation_cn0")


def code_sigma_m(cn0_dbhz, default_m: float = 3.0):
    """Code noise 1-sigma [m] from C/N0 (the ``cn0`` model above); NaN or
    missing C/N0 -> ``default_m``."""
    c = np.asarray(cn0_dbhz, float)
    s = np.sqrt(CN0_CONSTANT_M2HZ * 10.0 ** (-np.nan_to_num(c, nan=-np.inf) / 10.0))
    return np.where(np.isfinite(c) & (c > 0), np.clip(s, 0.1, 30.0), default_m)


@dataclass(frozen=True)
class ErrorModel:
    """Per-satellite pseudorange variance (see the module docstring); every
    number a parameter of the SPP command / the gnss_raw source."""
    weighting: str = "elevation_cn0"
    a_m: float = 0.3
    b_m: float = 0.3
    ura_default_m: float = 3.0
    ura_floor_m: float = 0.3
    iono_fraction: float = 0.5
    trop_zenith_sigma_m: float = 0.1

    def __post_init__(self):
        if self.weighting not in WEIGHTINGS:
            raise ValueError(f"weighting: expected one of {WEIGHTINGS}, got {self.weighting!r}")

    def receiver_var_m2(self, el_rad, cn0_dbhz, cn0_part=None):
        """Receiver noise + multipath variance of one signal [m^2].
        ``cn0_part``: :meth:`cn0_var_m2` of ``cn0_dbhz`` when the caller
        keeps it (it does not depend on the position; the same numbers)."""
        s = np.maximum(np.sin(np.asarray(el_rad, float)), 0.05)
        v_el = self.a_m ** 2 + self.b_m ** 2 / s ** 2
        if self.weighting == "elevation":
            return v_el
        finite, valid, var_c = cn0_part if cn0_part is not None else self.cn0_var_m2(cn0_dbhz)
        if valid.all():
            v_cn = var_c
        else:
            default_m = np.sqrt(v_el).max() if np.size(v_el) else 3.0
            v_cn = np.where(valid, var_c, default_m ** 2)
        v_cn = np.where(finite, v_cn, v_el)
        return v_cn if self.weighting == "cn0" else np.maximum(v_el, v_cn)

    @staticmethod
    def cn0_var_m2(cn0_dbhz):
        """(C/N0 finite, C/N0 finite and > 0, :func:`code_sigma_m` squared
        where valid): the position-independent part of :meth:`receiver_var_m2`."""
        c = np.asarray(cn0_dbhz, float)
        s = np.sqrt(CN0_CONSTANT_M2HZ * 10.0 ** (-np.nan_to_num(c, nan=-np.inf) / 10.0))
        valid = np.isfinite(c) & (c > 0)
        return np.isfinite(c), valid, np.where(valid, np.clip(s, 0.1, 30.0), 0.0) ** 2

    def model_var_m2(self, el_rad, accuracy_m, iono_m, dual_frequency):
        """Broadcast orbit/clock + residual ionosphere + troposphere variance [m^2]."""
        s = np.maximum(np.sin(np.asarray(el_rad, float)), 0.05)
        ura = np.asarray(accuracy_m, float)
        ura = np.where(np.isfinite(ura) & (ura > 0), ura, self.ura_default_m)
        ura = np.maximum(ura, self.ura_floor_m)
        iono = np.where(np.asarray(dual_frequency, bool), 0.0, self.iono_fraction * np.asarray(iono_m, float))
        return ura ** 2 + iono ** 2 + (self.trop_zenith_sigma_m / s) ** 2
