"""IMU error model applied to exact increments (datasheet units in, SI out).

Per axis, over each interval (t - dt, t] the sensor reports (gyro; the
accelerometer is the same with dv, f, VRW)::

    dtheta_out = Quant[ (I + S + M) dtheta_true
                        + (b + b_GM(t) + b_BI(t)) dt
                        + N sqrt(dt) w ]

* b      constant bias (turn-on bias), ``gyro_bias_deg_per_hr`` / ``accel_bias_ug``.
  Seed 000 section IV.B: gyro constant drift 0.1 deg/h, accelerometer zero
  bias 1e-3 g; seed 001 section 4: gyro 3 deg/h, accelerometer 1 mg.
* b_GM   first-order Gauss-Markov drift, stationary sigma and correlation
  time T: b_k+1 = exp(-dt/T) b_k + sigma sqrt(1 - exp(-2 dt/T)) w_k (exact
  discretisation; this is the ``-1/T`` bias model of seed 000 eq. 19, F_3).
* b_BI   bias instability (flicker, 1/f). Modelled as a *Markov sum*: n equal
  variance first-order Gauss-Markov processes with correlation times
  log-spaced over ``bias_instability_band_s`` (2 per decade). Its Allan
  deviation is flat (within 1 %) for tau between ~20 T_min and T_max / 20;
  the component sigma is set from the closed-form Allan variance of a
  Gauss-Markov process (IEEE Std 952-1997 annex C)::

      AVAR_GM(tau) = 2 s^2 T / tau [1 - T / (2 tau) (3 - 4 e^-tau/T + e^-2tau/T)]

  so that the flat floor at the band's geometric centre equals
  0.664 B (= sqrt(2 ln 2 / pi) B, the IEEE flicker floor), B being the
  configured ``gyro_bias_instability_deg_per_hr`` / ``accel_bias_instability_ug``.
* N      angle / velocity random walk (white rate noise, two-sided PSD N^2),
  ``gyro_arw_deg_per_sqrt_hr`` / ``accel_vrw_ug_per_sqrt_hz``. Per increment
  the noise is N sqrt(dt); the Allan deviation is N / sqrt(tau). Seed 000:
  0.01 deg/sqrt(h) and 100 ug/sqrt(Hz) ("white noise 0.01 deg/h, 1e-4 g");
  seed 001: 0.3 deg/h and 1e-4 g white.
* S      scale-factor error, diag(ppm * 1e-6), per axis (seed 001: 100 ppm).
* M      misalignment / non-orthogonality: small-angle matrix, zero diagonal,
  M[i, j] = coupling of true axis j into sensed axis i (arcsec or mrad).
* Quant  quantization to multiples of the angle / velocity quantum. The
  residual (true minus output) is carried into the next sample, so the
  summed output never differs from the summed analog increment by more
  than half a quantum (no accumulation).

Every term besides the four original scenario fields defaults to zero, and
with only those set the random draws are the same as before (gyro white
noise first, then accelerometer white noise, from the Generator passed in).
"""
from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from hyper_nav_filter.core import units

from hyper_nav_filter.core.params import number, unknown_field

ARCSEC = units.DEG / 3600.0
FLICKER_FLOOR = float(np.sqrt(2.0 * np.log(2.0) / np.pi))   # 0.6643, IEEE 952
_BI_PER_DECADE = 2


def _zeros3():
    return np.zeros(3)


def _zeros33():
    return np.zeros((3, 3))


def gm_allan_variance(tau_s, sigma, corr_time_s):
    """Closed-form Allan variance of a first-order Gauss-Markov process with
    stationary sigma and correlation time T (IEEE Std 952-1997, C.1.5)."""
    x = np.asarray(tau_s, dtype=float) / corr_time_s
    return (2.0 * sigma**2 * corr_time_s / np.asarray(tau_s, float)
            * (1.0 - (3.0 - 4.0 * np.exp(-x) + np.exp(-2.0 * x)) / (2.0 * x)))


def markov_sum_components(bias_instability, band_s):
    """(sigmas, correlation times) of the Markov sum whose Allan floor at the
    centre of ``band_s`` is 0.664 * bias_instability (same units as it)."""
    t_lo, t_hi = float(band_s[0]), float(band_s[1])
    n = int(np.ceil(_BI_PER_DECADE * np.log10(t_hi / t_lo))) + 1
    taus = np.logspace(np.log10(t_lo), np.log10(t_hi), n)
    unit_avar = gm_allan_variance(np.sqrt(t_lo * t_hi), 1.0, taus).sum()
    sigma = FLICKER_FLOOR * bias_instability / np.sqrt(unit_avar)
    return np.full(n, sigma), taus


@dataclass(frozen=True)
class ImuErrors:
    """IMU error terms, SI (rad/s, m/s^2, rad/sqrt(s), m/s/sqrt(s), rad, m/s)."""
    gyro_bias_b_radps: np.ndarray
    gyro_arw_rad_per_sqrt_s: float
    accel_bias_b_mps2: np.ndarray
    accel_vrw_mps_per_sqrt_s: float
    gyro_markov_sigma_radps: np.ndarray = field(default_factory=_zeros3)
    gyro_markov_tau_s: float = 3600.0
    accel_markov_sigma_mps2: np.ndarray = field(default_factory=_zeros3)
    accel_markov_tau_s: float = 3600.0
    gyro_bias_instability_radps: float = 0.0
    accel_bias_instability_mps2: float = 0.0
    bias_instability_band_s: tuple = (0.1, 1.0e5)
    gyro_scale_factor: np.ndarray = field(default_factory=_zeros3)     # dimensionless
    accel_scale_factor: np.ndarray = field(default_factory=_zeros3)
    gyro_misalignment_rad: np.ndarray = field(default_factory=_zeros33)
    accel_misalignment_rad: np.ndarray = field(default_factory=_zeros33)
    gyro_quantum_rad: float = 0.0
    accel_quantum_mps: float = 0.0

    # ---- construction ---------------------------------------------------------
    @classmethod
    def from_scenario(cls, sc) -> "ImuErrors":
        """From a Scenario: the four required ``imu.*`` fields, plus any optional
        field of ``from_config`` present in the scenario's ``imu:`` block."""
        block = {}
        data = getattr(sc, "data", None)
        if isinstance(data, dict) and isinstance(data.get("imu"), dict):
            block = {k: v for k, v in data["imu"].items() if k in CONFIG_FIELDS}
        for k in ("gyro_bias_deg_per_hr", "gyro_arw_deg_per_sqrt_hr", "accel_bias_ug",
                  "accel_vrw_ug_per_sqrt_hz"):
            block[k] = sc[f"imu.{k}"]
        return cls.from_config(block)

    @classmethod
    def from_config(cls, d: dict, prefix: str = "imu") -> "ImuErrors":
        """From a plain dict (the ``imu:`` block of a scenario), datasheet units.
        Every field is optional (zero default). ``rate_hz`` is allowed and
        ignored. Raises ValueError naming the bad field."""
        if d is None:
            d = {}
        if not isinstance(d, dict):
            raise ValueError(f"{prefix}: expected a mapping, got {d!r}")
        for k in d:
            if k not in CONFIG_FIELDS and k not in IGNORED_FIELDS:
                raise ValueError(unknown_field(f"{prefix}.", k, set(CONFIG_FIELDS) | IGNORED_FIELDS))
        for a, b in (("gyro_misalignment_arcsec", "gyro_misalignment_mrad"),
                     ("accel_misalignment_arcsec", "accel_misalignment_mrad")):
            if a in d and b in d:
                raise ValueError(f"{prefix}.{a}: give either {a} or {b}, not both")

        def get(name):
            kind, default = CONFIG_FIELDS[name]
            return _parse(f"{prefix}.{name}", d.get(name, default), kind)

        def misalign(stem):
            if f"{stem}_mrad" in d:
                return get(f"{stem}_mrad") * 1e-3
            return get(f"{stem}_arcsec") * ARCSEC

        band = get("bias_instability_band_s")
        if not 0.0 < band[0] < band[1]:
            raise ValueError(f"{prefix}.bias_instability_band_s: need 0 < min < max, got {list(band)}")
        for name in ("gyro_markov_tau_s", "accel_markov_tau_s"):
            if get(name) <= 0.0:
                raise ValueError(f"{prefix}.{name}: must be > 0")
        return cls(
            gyro_bias_b_radps=units.deg_per_hr(get("gyro_bias_deg_per_hr")),
            gyro_arw_rad_per_sqrt_s=float(units.deg_per_sqrt_hr(get("gyro_arw_deg_per_sqrt_hr"))),
            accel_bias_b_mps2=units.ug(get("accel_bias_ug")),
            accel_vrw_mps_per_sqrt_s=float(units.ug_per_sqrt_hz(get("accel_vrw_ug_per_sqrt_hz"))),
            gyro_markov_sigma_radps=units.deg_per_hr(get("gyro_markov_sigma_deg_per_hr")),
            gyro_markov_tau_s=float(get("gyro_markov_tau_s")),
            accel_markov_sigma_mps2=units.ug(get("accel_markov_sigma_ug")),
            accel_markov_tau_s=float(get("accel_markov_tau_s")),
            gyro_bias_instability_radps=float(units.deg_per_hr(get("gyro_bias_instability_deg_per_hr"))),
            accel_bias_instability_mps2=float(units.ug(get("accel_bias_instability_ug"))),
            bias_instability_band_s=(float(band[0]), float(band[1])),
            gyro_scale_factor=get("gyro_scale_factor_ppm") * 1e-6,
            accel_scale_factor=get("accel_scale_factor_ppm") * 1e-6,
            gyro_misalignment_rad=misalign("gyro_misalignment"),
            accel_misalignment_rad=misalign("accel_misalignment"),
            gyro_quantum_rad=float(get("gyro_quantum_urad")) * 1e-6,
            accel_quantum_mps=float(get("accel_quantum_mm_per_s")) * 1e-3,
        )


# field -> (kind, default); kinds: "vec3" a number (broadcast to 3 axes) or a
# list of 3, "vec3>=0" the same non-negative, "num>=0", "num>0", "mat3" a 3x3
# list with zero diagonal, "band" [min, max].
CONFIG_FIELDS = {
    "gyro_bias_deg_per_hr": ("vec3", 0.0),
    "gyro_arw_deg_per_sqrt_hr": ("num>=0", 0.0),
    "accel_bias_ug": ("vec3", 0.0),
    "accel_vrw_ug_per_sqrt_hz": ("num>=0", 0.0),
    "gyro_markov_sigma_deg_per_hr": ("vec3>=0", 0.0),
    "gyro_markov_tau_s": ("num>0", 3600.0),
    "accel_markov_sigma_ug": ("vec3>=0", 0.0),
    "accel_markov_tau_s": ("num>0", 3600.0),
    "gyro_bias_instability_deg_per_hr": ("num>=0", 0.0),
    "accel_bias_instability_ug": ("num>=0", 0.0),
    "bias_instability_band_s": ("band", [0.1, 1.0e5]),
    "gyro_scale_factor_ppm": ("vec3", 0.0),
    "accel_scale_factor_ppm": ("vec3", 0.0),
    "gyro_misalignment_arcsec": ("mat3", 0.0),
    "gyro_misalignment_mrad": ("mat3", 0.0),
    "accel_misalignment_arcsec": ("mat3", 0.0),
    "accel_misalignment_mrad": ("mat3", 0.0),
    "gyro_quantum_urad": ("num>=0", 0.0),
    "accel_quantum_mm_per_s": ("num>=0", 0.0),
}
IGNORED_FIELDS = {"rate_hz", "mounting_b_xyzw"}      # not error-model fields (the mounting: /tf_static)


def _is_num(x):
    return isinstance(x, (int, float, np.integer, np.floating)) and not isinstance(x, bool) and np.isfinite(x)


def _parse(name, value, kind):
    if kind.startswith("num"):
        return number(name, value, None if kind == "num" else 0.0, lo_open=kind == "num>0", error=ValueError)
    if kind.startswith("vec3"):
        if _is_num(value):
            v = np.full(3, float(value))
        elif isinstance(value, (list, tuple, np.ndarray)) and len(value) == 3 and all(_is_num(x) for x in value):
            v = np.asarray(value, dtype=float)
        else:
            raise ValueError(f"{name}: expected a number or a list of 3 numbers, got {value!r}")
        if kind == "vec3>=0" and np.any(v < 0):
            raise ValueError(f"{name}: must be >= 0, got {v.tolist()}")
        return v
    if kind == "mat3":
        if _is_num(value) and float(value) == 0.0:
            return np.zeros((3, 3))
        m = np.asarray(value, dtype=object) if isinstance(value, (list, tuple, np.ndarray)) else None
        if m is None or m.shape != (3, 3) or not all(_is_num(x) for x in m.ravel()):
            raise ValueError(f"{name}: expected a 3x3 list of numbers, got {value!r}")
        m = m.astype(float)
        if np.any(np.diag(m) != 0.0):
            raise ValueError(f"{name}: diagonal must be zero (scale factor is separate), got {m.tolist()}")
        return m
    if kind == "band":
        if not (isinstance(value, (list, tuple)) and len(value) == 2 and all(_is_num(x) for x in value)):
            raise ValueError(f"{name}: expected [min, max] correlation times in s, got {value!r}")
        return np.asarray(value, dtype=float)
    raise AssertionError(kind)


@dataclass
class ImuErrorState:
    """Carried between calls of ``corrupt_increments`` for a streaming
    sensor: Gauss-Markov states and quantization residuals. ``None`` fields
    are initialised on first use (stationary draw / zero residual)."""
    gyro_markov_radps: np.ndarray | None = None
    accel_markov_mps2: np.ndarray | None = None
    gyro_bi_radps: np.ndarray | None = None       # (n_components, 3)
    accel_bi_mps2: np.ndarray | None = None
    gyro_residual_rad: np.ndarray = field(default_factory=_zeros3)
    accel_residual_mps: np.ndarray = field(default_factory=_zeros3)


def gauss_markov(n, dt_s, sigma, tau_s, rng, x0=None):
    """(n, 3) samples of first-order Gauss-Markov processes (exact
    discretisation), stationary sigma per axis; x0 the state before sample 0
    (drawn stationary if None). Returns (samples, last state)."""
    sigma = np.broadcast_to(np.asarray(sigma, float), (3,))
    phi = np.exp(-dt_s / tau_s)
    if x0 is None:
        x0 = sigma * rng.standard_normal(3)
    w = rng.standard_normal((n, 3)) * sigma * np.sqrt(1.0 - phi**2)
    # x_k = phi x_{k-1} + w_k, with initial condition x_{-1} = x0. scipy.signal is
    # imported here, not at module level: it costs 2.3 s of start-up in every
    # sensor node (measured), and only IMUs with Markov terms need it
    from scipy.signal import lfilter
    zi = (phi * np.asarray(x0, float))[None, :]
    x = lfilter([1.0], [1.0, -phi], w, axis=0, zi=zi)[0]
    return x, x[-1].copy()


def _markov_sum(n, dt_s, bias_instability, band_s, rng, state):
    sig, taus = markov_sum_components(bias_instability, band_s)
    total = np.zeros((n, 3))
    new_state = np.empty((len(taus), 3))
    for j, (s, t) in enumerate(zip(sig, taus)):
        x, new_state[j] = gauss_markov(n, dt_s, s, t, rng, None if state is None else state[j])
        total += x
    return total, new_state


def quantize(increments, quantum, residual0=None):
    """Quantize (N, 3) increments to multiples of ``quantum``, carrying the
    residual between samples: the running sum of the output is the running
    sum of the input rounded to the quantum grid, so it never drifts by more
    than quantum / 2. Returns (output, residual after the last sample)."""
    if quantum <= 0.0:
        return increments, np.zeros(3) if residual0 is None else residual0
    r0 = np.zeros(3) if residual0 is None else np.asarray(residual0, float)
    s = r0 + np.cumsum(increments, axis=0)
    counts = np.rint(s / quantum)
    c_prev = np.vstack([np.zeros((1, 3)), counts[:-1]])
    out = (counts - c_prev) * quantum
    return out, s[-1] - counts[-1] * quantum


def corrupt_increments(dtheta_b_rad, dvel_b_mps, dt_s, errors: ImuErrors, rng: np.random.Generator,
                       state: ImuErrorState | None = None):
    """Apply the error model to exact increments (arrays (N, 3)) over
    intervals of dt_s. ``state`` (optional) is updated in place so that
    consecutive calls form one continuous error process."""
    e = errors
    n = dtheta_b_rad.shape[0]
    st = state if state is not None else ImuErrorState()
    # draw order: the two white noises first (unchanged from the original model)
    dth = (dtheta_b_rad + e.gyro_bias_b_radps * dt_s
           + rng.standard_normal((n, 3)) * e.gyro_arw_rad_per_sqrt_s * np.sqrt(dt_s))
    dv = (dvel_b_mps + e.accel_bias_b_mps2 * dt_s
          + rng.standard_normal((n, 3)) * e.accel_vrw_mps_per_sqrt_s * np.sqrt(dt_s))
    g_lin = np.diag(e.gyro_scale_factor) + e.gyro_misalignment_rad
    a_lin = np.diag(e.accel_scale_factor) + e.accel_misalignment_rad
    if np.any(g_lin):
        dth = dth + dtheta_b_rad @ g_lin.T
    if np.any(a_lin):
        dv = dv + dvel_b_mps @ a_lin.T
    if np.any(e.gyro_markov_sigma_radps):
        x, st.gyro_markov_radps = gauss_markov(n, dt_s, e.gyro_markov_sigma_radps, e.gyro_markov_tau_s,
                                               rng, st.gyro_markov_radps)
        dth = dth + x * dt_s
    if np.any(e.accel_markov_sigma_mps2):
        x, st.accel_markov_mps2 = gauss_markov(n, dt_s, e.accel_markov_sigma_mps2, e.accel_markov_tau_s,
                                               rng, st.accel_markov_mps2)
        dv = dv + x * dt_s
    if e.gyro_bias_instability_radps > 0.0:
        x, st.gyro_bi_radps = _markov_sum(n, dt_s, e.gyro_bias_instability_radps,
                                          e.bias_instability_band_s, rng, st.gyro_bi_radps)
        dth = dth + x * dt_s
    if e.accel_bias_instability_mps2 > 0.0:
        x, st.accel_bi_mps2 = _markov_sum(n, dt_s, e.accel_bias_instability_mps2,
                                          e.bias_instability_band_s, rng, st.accel_bi_mps2)
        dv = dv + x * dt_s
    dth, st.gyro_residual_rad = quantize(dth, e.gyro_quantum_rad, st.gyro_residual_rad)
    dv, st.accel_residual_mps = quantize(dv, e.accel_quantum_mps, st.accel_residual_mps)
    return dth, dv


def imu_epochs(duration_s: float, rate_hz: float) -> np.ndarray:
    """IMU epochs (end of each interval) from 1/rate to duration, on sim time."""
    n = int(np.floor(duration_s * rate_hz + 1e-9))
    return np.arange(1, n + 1) / rate_hz


__all__ = ["ImuErrors", "ImuErrorState", "CONFIG_FIELDS", "corrupt_increments", "imu_epochs",
           "quantize", "gauss_markov", "gm_allan_variance", "markov_sum_components", "FLICKER_FLOOR"]
