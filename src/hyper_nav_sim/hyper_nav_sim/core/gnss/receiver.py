"""GNSS receiver simulator on a trajectory: raw measurements, lock state and a
least-squares PVT fix per epoch, from the file-free nominal constellation.

Configuration is the ``gnss:`` block of a scenario YAML (plain dict), see
:class:`GnssReceiverConfig` for fields, units and defaults. Per epoch
(:meth:`GnssReceiverSim.simulate`):

1. Truth of the vehicle (``trajectory.truth(t)``: geodetic position, ENU
   velocity, attitude, omega_ib_b) -> antenna position/velocity in ECEF with
   the body lever arm l_b: r_a = r + C_b_e l_b, v_a = v + C_b_e (omega_eb_b x l_b),
   omega_eb_b = omega_ib_b - C_n_b omega_ie_n.
2. Satellites of the ephemeris set in use (nominal constellation with toe at the
   start of each 2-hour block from ``start_gpst_s``) above the elevation mask at
   the antenna are the channels.
3. Observables (:func:`.observables.compute_observables`): pseudorange,
   pseudorange rate, Doppler, with the receiver clock truth (two-state Allan
   model), the delays, satellite orbits and clocks of the simulated world
   (:mod:`.world`: the broadcast models themselves in the perfect-model
   world, independent ones in the realistic world) and (with an rng) noise.
4. Lock (:class:`.lock.LockModel`): vehicle-induced Doppler u.v_a/lambda and its
   rate (u_dot.v_a + u.a_a)/lambda from the truth motion; scripted outages.
   With the ``tracking:`` block (off by default) lock is instead the outcome
   of the 1 kHz tracking simulation (:mod:`.receiver_tracking`): C/N0 from the
   signal environment (antenna pattern on the truth attitude, plasma sheath),
   loops unaided or aided; the loops' code and Doppler errors are added to the
   measurements, C/N0 is the receiver's estimate, lock time and tracking flags
   are reported.
5. PVT (:func:`.pvt.solve_pvt`) from the locked satellites, corrected with the
   same broadcast iono/tropo models, when at least 4 (+1 per further system)
   are locked; else ``None``.

Values of unlocked channels are still filled in (what the receiver would
measure if tracking) and flagged ``locked = False``; consumers must use only
locked ones.
"""
from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from hyper_nav_filter.core.params import number

from hyper_nav_gnss import earth
from hyper_nav_gnss.orbits.ephemeris import C_MPS, satellite_position_ecef, system_time_s
from hyper_nav_gnss.geometry import elevation_azimuth
from hyper_nav_gnss.corrections.propagation import KLOBUCHAR_ALPHA_DEFAULT, KLOBUCHAR_BETA_DEFAULT
from hyper_nav_gnss.observations import RawGnssEpoch

from hyper_nav_gnss.receiver.lock import LockConfig, LockModel
from hyper_nav_gnss.orbits.nominal import gpst_from_date, nominal_constellation
from .observables import CARRIER_HZ, ClockModel, compute_observables, pr_sigma_m
from hyper_nav_gnss.positioning.pvt import solve_pvt
from .world import GnssWorld

EPHEMERIS_BLOCK_S = 7200.0

_TOP_FIELDS = {"systems", "start_gpst_s", "rate_hz", "elevation_mask_deg", "pseudorange_sigma_m",
               "pseudorange_rate_sigma_mps", "clock", "ionosphere", "troposphere", "lock",
               "antenna_lever_arm_b_m", "klobuchar_alpha", "klobuchar_beta", "ionosphere_truth_scale",
               "cn0_zenith_dbhz", "cn0_horizon_dbhz", "ephemeris_seed", "gps_spares", "tracking"}
_CLOCK_FIELDS = {"h0", "h_m2", "bias_m", "drift_mps"}
_LOCK_FIELDS = {"doppler_limit_hz", "doppler_reference", "loop_bandwidth_hz", "phase_error_limit_deg",
                "reacquisition_s", "outages", "sat_outages"}


def _num(name, v, lo=None, hi=None, lo_open=False):
    """A field of the ``gnss`` block (``params.number``: the rule of every declared number)."""
    return number(f"gnss.{name}", v, lo, hi, lo_open=lo_open, error=ValueError)


def _windows(name, v):
    try:
        w = [(float(a), float(b)) for a, b in (v or [])]
    except (TypeError, ValueError):
        raise ValueError(f"gnss.{name}: expected a list of [t0, t1] pairs [s], got {v!r}") from None
    if any(not b > a for a, b in w):
        raise ValueError(f"gnss.{name}: every window needs t1 > t0, got {v!r}")
    return w


@dataclass
class GnssReceiverConfig:
    """Receiver configuration (units in the names).

    systems ['G'] | ['G', 'C']; start_gpst_s: continuous GPST [s] at scenario
    t = 0 (or a GPST calendar string, see :func:`.nominal.gpst_from_date`);
    pseudorange_sigma_m: a number [m] or 'elevation' (seed 004 eq. 11,
    0.11 + 0.13 exp(-E/4deg)); clock: h0 [s], h_m2 [1/s], initial bias_m [m],
    drift_mps [m/s]; ionosphere 'klobuchar' | 'off' (klobuchar_alpha/beta
    override the nominal coefficients; the PVT corrects with the broadcast
    model; the truth is the simulator's world, see :mod:`.world`; in the
    perfect-model world it is ionosphere_truth_scale x the broadcast model); troposphere 'hopfield' | 'off'; lock: :class:`.lock.LockConfig`
    fields (outages [[t0, t1], ...] in scenario seconds); antenna lever arm in
    body FLU axes [m]; C/N0 linear in sin(elevation) between horizon and zenith values."""
    systems: tuple = ("G",)
    start_gpst_s: float = 0.0
    rate_hz: float = 1.0
    elevation_mask_deg: float = 7.5
    pseudorange_sigma_m: object = "elevation"
    pseudorange_rate_sigma_mps: float = 0.05
    clock_h0: float = 2e-19
    clock_h_m2: float = 2e-20
    clock_bias_m: float = 0.0
    clock_drift_mps: float = 0.0
    ionosphere: str = "klobuchar"
    troposphere: str = "hopfield"
    klobuchar_alpha: tuple = KLOBUCHAR_ALPHA_DEFAULT
    klobuchar_beta: tuple = KLOBUCHAR_BETA_DEFAULT
    ionosphere_truth_scale: float = 1.0
    lock: LockConfig = field(default_factory=LockConfig)
    antenna_lever_arm_b_m: np.ndarray = field(default_factory=lambda: np.zeros(3))
    cn0_zenith_dbhz: float = 48.0
    cn0_horizon_dbhz: float = 36.0
    ephemeris_seed: int = 0
    gps_spares: int = 4
    tracking: object = None           # :class:`.receiver_tracking.TrackingConfig` or None (off)

    @classmethod
    def from_dict(cls, d: dict | None) -> "GnssReceiverConfig":
        d = dict(d or {})
        bad = set(d) - _TOP_FIELDS
        if bad:
            raise ValueError(f"gnss: unknown field(s) {sorted(bad)}; allowed {sorted(_TOP_FIELDS)}")
        c = cls()
        if "systems" in d:
            s = d["systems"]
            if isinstance(s, str) or not s or any(x not in ("G", "C") for x in s) or len(set(s)) != len(s):
                raise ValueError(f"gnss.systems: expected ['G'] or ['G', 'C'], got {s!r}")
            c.systems = tuple(s)
        if "start_gpst_s" in d:
            v = d["start_gpst_s"]
            c.start_gpst_s = gpst_from_date(v) if isinstance(v, str) else _num("start_gpst_s", v, 0.0)
        if "rate_hz" in d:
            c.rate_hz = _num("rate_hz", d["rate_hz"], 0.0, 100.0, lo_open=True)
        if "elevation_mask_deg" in d:
            c.elevation_mask_deg = _num("elevation_mask_deg", d["elevation_mask_deg"], -10.0, 60.0)
        if "pseudorange_sigma_m" in d:
            v = d["pseudorange_sigma_m"]
            c.pseudorange_sigma_m = "elevation" if v in ("elevation", "paper") else \
                _num("pseudorange_sigma_m", v, 0.0, lo_open=True)
        if "pseudorange_rate_sigma_mps" in d:
            c.pseudorange_rate_sigma_mps = _num("pseudorange_rate_sigma_mps", d["pseudorange_rate_sigma_mps"],
                                                0.0, lo_open=True)
        clk = d.get("clock") or {}
        if not isinstance(clk, dict) or set(clk) - _CLOCK_FIELDS:
            raise ValueError(f"gnss.clock: expected a mapping with fields {sorted(_CLOCK_FIELDS)}, got {clk!r}")
        c.clock_h0 = _num("clock.h0", clk.get("h0", c.clock_h0), 0.0)
        c.clock_h_m2 = _num("clock.h_m2", clk.get("h_m2", c.clock_h_m2), 0.0)
        c.clock_bias_m = _num("clock.bias_m", clk.get("bias_m", c.clock_bias_m))
        c.clock_drift_mps = _num("clock.drift_mps", clk.get("drift_mps", c.clock_drift_mps))
        if d.get("ionosphere", c.ionosphere) not in ("klobuchar", "off"):
            raise ValueError(f"gnss.ionosphere: expected 'klobuchar' or 'off', got {d['ionosphere']!r}")
        c.ionosphere = d.get("ionosphere", c.ionosphere)
        if d.get("troposphere", c.troposphere) not in ("hopfield", "off"):
            raise ValueError(f"gnss.troposphere: expected 'hopfield' or 'off', got {d['troposphere']!r}")
        c.troposphere = d.get("troposphere", c.troposphere)
        for k in ("klobuchar_alpha", "klobuchar_beta"):
            if k in d:
                v = d[k]
                if not isinstance(v, (list, tuple)) or len(v) != 4:
                    raise ValueError(f"gnss.{k}: expected 4 numbers, got {v!r}")
                setattr(c, k, tuple(_num(f"{k}[{i}]", x) for i, x in enumerate(v)))
        if "ionosphere_truth_scale" in d:
            c.ionosphere_truth_scale = _num("ionosphere_truth_scale", d["ionosphere_truth_scale"], 0.0)
        lk = d.get("lock") or {}
        if not isinstance(lk, dict) or set(lk) - _LOCK_FIELDS:
            raise ValueError(f"gnss.lock: expected a mapping with fields {sorted(_LOCK_FIELDS)}, got {lk!r}")
        ref = lk.get("doppler_reference", "vehicle")
        if ref not in ("vehicle", "total"):
            raise ValueError(f"gnss.lock.doppler_reference: expected 'vehicle' or 'total', got {ref!r}")
        sat_out = lk.get("sat_outages") or {}
        if not isinstance(sat_out, dict):
            raise ValueError(f"gnss.lock.sat_outages: expected {{'G05': [[t0, t1]]}}, got {sat_out!r}")
        c.lock = LockConfig(
            doppler_limit_hz=_num("lock.doppler_limit_hz", lk.get("doppler_limit_hz", 5000.0), 0.0, lo_open=True),
            doppler_reference=ref,
            loop_bandwidth_hz=_num("lock.loop_bandwidth_hz", lk.get("loop_bandwidth_hz", 15.0), 0.0, lo_open=True),
            phase_error_limit_deg=_num("lock.phase_error_limit_deg", lk.get("phase_error_limit_deg", 30.0), 0.0,
                                       lo_open=True),
            reacquisition_s=_num("lock.reacquisition_s", lk.get("reacquisition_s", 2.0), 0.0),
            outages=_windows("lock.outages", lk.get("outages")),
            sat_outages={str(k): _windows(f"lock.sat_outages.{k}", v) for k, v in sat_out.items()})
        if "antenna_lever_arm_b_m" in d:
            v = d["antenna_lever_arm_b_m"]
            if not isinstance(v, (list, tuple, np.ndarray)) or len(v) != 3:
                raise ValueError(f"gnss.antenna_lever_arm_b_m: expected 3 numbers [m], got {v!r}")
            c.antenna_lever_arm_b_m = np.array([_num(f"antenna_lever_arm_b_m[{i}]", x, -100, 100)
                                                for i, x in enumerate(v)])
        for k in ("cn0_zenith_dbhz", "cn0_horizon_dbhz"):
            if k in d:
                setattr(c, k, _num(k, d[k], 0.0, 70.0))
        if "ephemeris_seed" in d:
            c.ephemeris_seed = int(_num("ephemeris_seed", d["ephemeris_seed"], 0.0))
        if "gps_spares" in d:
            c.gps_spares = int(_num("gps_spares", d["gps_spares"], 0.0, 4.0))
        if d.get("tracking") is not None:
            from hyper_nav_sim.core.gnss.receiver_tracking import TrackingConfig
            if not isinstance(d["tracking"], dict):
                raise ValueError(f"gnss.tracking: expected a mapping, got {d['tracking']!r}")
            c.tracking = TrackingConfig.from_dict(d["tracking"])
        return c


@dataclass
class GnssFix:
    """Least-squares fix. Position refers to the antenna at true time t."""
    r_e_m: np.ndarray
    v_e_mps: np.ndarray
    lat_rad: float
    lon_rad: float
    alt_m: float
    vel_enu_mps: np.ndarray
    cov_pos_e_m2: np.ndarray          # 3x3 ECEF
    cov_pos_enu_m2: np.ndarray        # 3x3 ENU
    cov_vel_e_m2ps2: np.ndarray       # 3x3 ECEF
    cov_vel_enu_m2ps2: np.ndarray
    clk_bias_m: float
    clk_drift_mps: float
    isb_m: dict
    dop: dict
    n_sats: int
    sat_ids: list
    clk_drift_sigma_mps: float = float("nan")   # from the PVT's velocity/drift covariance


@dataclass
class GnssEpoch:
    """One epoch: channel arrays (satellites above the mask, N entries) + truth + fix."""
    t_s: float                        # scenario time
    t_gpst_s: float                   # true reception time, continuous GPST
    t_tag_s: float                    # receiver time tag = t_gpst + clk_bias/c
    sat_ids: list
    system: list
    prn: np.ndarray
    pseudorange_m: np.ndarray
    pseudorange_rate_mps: np.ndarray
    doppler_hz: np.ndarray
    carrier_hz: np.ndarray
    cn0_dbhz: np.ndarray
    elevation_rad: np.ndarray
    azimuth_rad: np.ndarray
    locked: np.ndarray
    pr_sigma_m: np.ndarray
    rate_sigma_mps: np.ndarray
    iono_model_m: np.ndarray          # broadcast-model delays the receiver would correct
    tropo_model_m: np.ndarray
    vehicle_doppler_hz: np.ndarray
    vehicle_doppler_rate_hzps: np.ndarray
    geometric_rate_mps: np.ndarray    # truth, clock-free
    ephemerides: list                 # records of the channels (same order)
    ephemeris_set: list               # the full set in use
    clock_bias_m: float               # receiver clock truth
    clock_drift_mps: float
    antenna_r_e_m: np.ndarray         # truth
    antenna_v_e_mps: np.ndarray
    fix: GnssFix | None
    iono_true_m: np.ndarray | None = None     # delays the signals went through (the world)
    tropo_true_m: np.ndarray | None = None
    # with the tracking option (gnss.tracking): what the receiver reports per channel
    lock_time_s: np.ndarray | None = None     # continuous carrier-lock time [s]
    tracking_flags: np.ndarray | None = None  # GnssMeasurements.TRACK_* bits
    cn0_true_dbhz: np.ndarray | None = None   # signal environment truth (cn0_dbhz is the estimate)

    def raw(self) -> RawGnssEpoch:
        """What the receiver outputs at this epoch (the content of ``gnss/raw``)
        in the filter's input type; the time tag is t_tag_s."""
        return RawGnssEpoch(self.t_s, self.t_tag_s, tuple(self.system), np.asarray(self.prn, int),
                            self.pseudorange_m, self.pr_sigma_m, self.pseudorange_rate_mps, self.rate_sigma_mps,
                            np.asarray(self.locked, bool))


def _sample_clock(cfg: GnssReceiverConfig, t, rng):
    b0, d0 = cfg.clock_bias_m, cfg.clock_drift_mps
    if rng is None or (cfg.clock_h0 == 0.0 and cfg.clock_h_m2 == 0.0):
        return b0 + d0 * (t - t[0]), np.full(t.size, d0)
    cm = ClockModel(cfg.clock_h0, cfg.clock_h_m2)
    x = np.array([b0, d0])
    out = np.empty((t.size, 2))
    out[0] = x
    for k in range(1, t.size):
        dt = t[k] - t[k - 1]
        w, V = np.linalg.eigh(cm.q_matrix(dt))
        x = np.array([x[0] + dt * x[1], x[1]]) + V @ (np.sqrt(np.maximum(w, 0.0)) * rng.standard_normal(2))
        out[k] = x
    return out[:, 0], out[:, 1]


class GnssReceiverSim:
    """``world``: the :class:`.world.GnssWorld` the signals go through; None =
    the perfect model (truth = the broadcast models and records, with the
    ionosphere scaled by ``ionosphere_truth_scale``)."""

    def __init__(self, config: GnssReceiverConfig | dict | None = None, world=None):
        self.cfg = config if isinstance(config, GnssReceiverConfig) else GnssReceiverConfig.from_dict(config)
        self._sets: dict[int, list] = {}
        self.world = world if world is not None else GnssWorld.perfect(
            self.broadcast_ionosphere(), self.cfg.troposphere == "hopfield", self.cfg.ionosphere_truth_scale)

    def broadcast_ionosphere(self) -> dict | None:
        """{system: (alpha, beta)} the satellites broadcast (None: ionosphere off)."""
        c = self.cfg
        if c.ionosphere != "klobuchar":
            return None
        return {s: (np.array(c.klobuchar_alpha), np.array(c.klobuchar_beta)) for s in c.systems}

    # ---- ephemerides ---------------------------------------------------------------------------
    def ephemeris_set(self, t_s: float) -> list:
        """Nominal records in use at scenario time t_s (toe at the start of its 2-h block)."""
        k = int(np.floor(t_s / EPHEMERIS_BLOCK_S))
        if k not in self._sets:
            c = self.cfg
            self._sets[k] = nominal_constellation(c.start_gpst_s + k * EPHEMERIS_BLOCK_S, c.systems,
                                                  c.ephemeris_seed, clock_ref_gpst_s=c.start_gpst_s,
                                                  gps_spares=c.gps_spares)
        return self._sets[k]

    def epochs(self, t0_s: float, t1_s: float) -> np.ndarray:
        """Measurement epochs [s] at rate_hz in [t0, t1]."""
        dt = 1.0 / self.cfg.rate_hz
        return t0_s + dt * np.arange(int(np.floor((t1_s - t0_s) / dt + 1e-9)) + 1)

    # ---- antenna truth ------------------------------------------------------------------------------
    def antenna_truth(self, trajectory, t_s):
        """Antenna ECEF position (N,3), velocity (N,3) and acceleration (N,3, central
        difference over +-ANTENNA_DIFF_S) from ``trajectory.truth``."""
        t = np.atleast_1d(np.asarray(t_s, float))
        h = ANTENNA_DIFF_S
        tt = np.concatenate([t, t - h, t + h])
        tr = trajectory.truth(tt)
        lat, lon, alt = tr.lat_rad, tr.lon_rad, tr.alt_m
        r = earth.geodetic_to_ecef(lat, lon, alt)
        Cne = np.stack([earth.C_n_e(a, b) for a, b in zip(lat, lon)])
        v = np.einsum("kij,kj->ki", Cne, tr.vel_enu_mps)
        lb = np.asarray(self.cfg.antenna_lever_arm_b_m, float)
        if np.any(lb):
            C_b_e = np.einsum("kij,kjl->kil", Cne, tr.C_b_n)
            w_ie_b = np.einsum("kji,kj->ki", tr.C_b_n, earth.omega_ie_n(lat))
            w_eb_b = tr.omega_ib_b_radps - w_ie_b
            r = r + np.einsum("kij,j->ki", C_b_e, lb)
            v = v + np.einsum("kij,kj->ki", C_b_e, np.cross(w_eb_b, lb))
        n = t.size
        a = (v[2 * n:] - v[n:2 * n]) / (2 * h)
        return r[:n], v[:n], a

    @staticmethod
    def _sky(eset, t_gpst):
        """Geometric ECEF positions (n_sat, n_t, 3) of a set over epochs (one
        vectorised call per satellite)."""
        r = np.stack([satellite_position_ecef(e, np.atleast_1d(system_time_s(e.system, t_gpst)))[0]
                      for e in eset])
        return r

    # ---- simulation ----------------------------------------------------------------------------------
    def simulate(self, trajectory, t_epochs_s, rng: np.random.Generator | None = None) -> list[GnssEpoch]:
        """Epochs at scenario times ``t_epochs_s`` (ascending). rng None -> noise-free
        measurements and a deterministic clock (bias + drift t)."""
        run = self.run(trajectory, t_epochs_s, rng)
        return [run.epoch(k) for k in range(len(run.t_ep))]

    def run(self, trajectory, t_epochs_s, rng: np.random.Generator | None = None,
            lazy: bool = False) -> "ReceiverRun":
        """The same simulation one epoch at a time (:meth:`ReceiverRun.epoch`), for a
        receiver aided by a navigation state that arrives while it runs (gnss_node).
        ``lazy``: the antenna truth of epoch k is taken when epoch k is computed
        (a flight flown as it goes, ``core.flown_streams.FlownRaw``: it must be
        flown to t_k + ``ANTENNA_DIFF_S``); not with the tracking option."""
        return ReceiverRun(self, trajectory, t_epochs_s, rng, lazy=lazy)


ANTENNA_DIFF_S = 0.05      # the antenna acceleration's central difference: truth is needed to t + this


class ReceiverRun:
    """State of one receiver simulation between epochs; epochs in ascending order."""

    def __init__(self, sim: GnssReceiverSim, trajectory, t_epochs_s, rng, lazy: bool = False):
        c = self.cfg = sim.cfg
        self.sim, self.rng = sim, rng
        t_ep = self.t_ep = np.asarray(t_epochs_s, float)
        self.lazy, self.trajectory = bool(lazy), trajectory
        if lazy:
            if c.tracking is not None:
                raise ValueError("gnss.raw.tracking: the receiver's tracking loops are not simulated on a flight "
                                 "flown as it goes (a commanded flight): remove the tracking block")
            self.r_a, self.v_a, self.a_a = (np.full((len(t_ep), 3), np.nan) for _ in range(3))
            self._have = np.zeros(len(t_ep), bool)
        else:
            self.r_a, self.v_a, self.a_a = sim.antenna_truth(trajectory, t_ep)
        self.clk_b, self.clk_d = _sample_clock(c, t_ep, rng)
        self.lock = LockModel(c.lock)
        self.trk = None
        if c.tracking is not None:
            from hyper_nav_filter.core import atmosphere
            from hyper_nav_sim.core.gnss.receiver_tracking import ReceiverTracking
            self.trk = ReceiverTracking(c.tracking, rng)
            self.tr_all = trajectory.truth(t_ep)
            self.mach_all = (np.linalg.norm(self.tr_all.vel_enu_mps, axis=1)
                             / atmosphere.speed_of_sound_mps(self.tr_all.alt_m))
        self.iono_model = sim.broadcast_ionosphere()
        self.sig_fn = (pr_sigma_m if c.pseudorange_sigma_m == "elevation"
                       else (lambda el: np.full(np.shape(el), float(c.pseudorange_sigma_m))))
        self.r_prev = self.v_prev = self.t_prev = None
        self.blocks = np.floor(t_ep / EPHEMERIS_BLOCK_S)
        self.vis_cache = {}
        self.last_fix = None            # (t_s, GnssFix)
        self.drift_hat = None           # (t_s, m/s, m^2/s^2): the receiver's own clock-drift estimate and
                                        # variance for the aiding

    def _drift_at(self, t):
        """The receiver's clock-drift estimate [m/s] and its sigma predicted to t
        (two-state clock model: drift random walk q = 2 pi^2 h_-2 c^2 per s, Brown & Hwang)."""
        t0, x, P = self.drift_hat
        q_d = 2.0 * np.pi ** 2 * self.cfg.clock_h_m2 * C_MPS ** 2
        return x, float(np.sqrt(P + q_d * max(t - t0, 0.0)))

    def _aid(self, k, t, aiding, u, carrier_hz):
        """(Doppler residual [Hz], LOS velocity sigma [m/s], range sigma [m]) per
        satellite from the navigation state held by ``aiding`` (:mod:`.aiding`), or
        None (no fresh state, or no fix yet: the receiver's clock drift is unknown)."""
        if aiding is None or self.drift_hat is None:
            return None
        from hyper_nav_gnss.receiver.aiding import doppler_residual_hz, los_sigmas
        pred = aiding.predict(float(t))
        if pred is None:
            return None
        drift_hat, s_drift = self._drift_at(float(t))
        res = doppler_residual_hz(pred, u, self.v_a[k], self.clk_d[k] - drift_hat, carrier_hz)
        s_v, s_r = los_sigmas(pred, u, s_drift, 30.0 + s_drift * max(float(t) - self.drift_hat[0], 0.0))
        return res, s_v, s_r

    def epoch(self, k: int, aiding=None) -> GnssEpoch:
        """Epoch k; ``aiding``: an :class:`.aiding.AidingInput` (``nav_state``
        aiding) or None."""
        c, sim, rng, trk = self.cfg, self.sim, self.rng, self.trk
        if self.lazy and not self._have[k]:      # the antenna truth of this epoch, now that it is flown
            r, v, a = sim.antenna_truth(self.trajectory, self.t_ep[k:k + 1])
            self.r_a[k], self.v_a[k], self.a_a[k] = r[0], v[0], a[0]
            self._have[k] = True
        t_ep, r_a, v_a, a_a, clk_b, clk_d = self.t_ep, self.r_a, self.v_a, self.a_a, self.clk_b, self.clk_d
        lock, iono_model, sig_fn = self.lock, self.iono_model, self.sig_fn
        blocks, vis_cache = self.blocks, self.vis_cache
        r_prev, v_prev, t_prev = self.r_prev, self.v_prev, self.t_prev
        t = t_ep[k]
        t_g = c.start_gpst_s + t
        eset = sim.ephemeris_set(t)
        if blocks[k] not in vis_cache:
            vis_cache.clear()
            vis_cache[blocks[k]] = (sim._sky(eset, c.start_gpst_s + t_ep[blocks == blocks[k]]), k)
        r_sat_all, k0 = vis_cache[blocks[k]]
        r_sat_k = r_sat_all[:, k - k0]
        el_all, _ = elevation_azimuth(r_a[k], r_sat_k)
        keep = np.flatnonzero(el_all >= np.deg2rad(c.elevation_mask_deg))
        ephs = [eset[i] for i in keep]
        sat_ids = [e.sat_id for e in ephs]
        n = len(ephs)
        if n:
            obs = compute_observables(ephs, t_g, r_a[k], v_a[k], clk_b[k], clk_d[k], iono=iono_model,
                                      tropo=c.troposphere == "hopfield", rng=rng,
                                      rate_sigma_mps=c.pseudorange_rate_sigma_mps, pr_sigma_fn=sig_fn,
                                      world=sim.world)
            pr = obs.pseudorange_m
            lam = C_MPS / obs.carrier_hz
            # line of sight in ECEF(t) and its rate, vehicle Doppler and rate
            d = r_sat_k[keep] - r_a[k]
            rho = np.linalg.norm(d, axis=1)
            u = d / rho[:, None]
            v_rel = obs.v_sat_e_mps - v_a[k]
            u_dot = (v_rel - u * np.einsum("ki,ki->k", u, v_rel)[:, None]) / rho[:, None]
            fd_veh = u @ v_a[k] / lam
            fd_veh_rate = (np.einsum("ki,i->k", u_dot, v_a[k]) + u @ a_a[k]) / lam
            fd_lock = fd_veh if c.lock.doppler_reference == "vehicle" else -obs.geometric_rate_mps / lam
            el = obs.el_rad
            te = None
            if trk is None:
                locked = lock.update(float(t), sat_ids, fd_lock, fd_veh_rate)
                cn0 = c.cn0_horizon_dbhz + (c.cn0_zenith_dbhz - c.cn0_horizon_dbhz) * np.sin(np.maximum(el, 0.0))
            else:
                # lock from the 1 kHz tracking simulation (satellite Doppler rate, < 1 Hz/s, left out)
                te = trk.step(float(t), sat_ids, obs.doppler_hz, fd_veh_rate, el, obs.az_rad,
                              self.tr_all.C_b_n[k], self.tr_all.alt_m[k], self.mach_all[k], obs.carrier_hz,
                              aid=self._aid(k, t, aiding, u, obs.carrier_hz) if trk.external else None)
                locked = te.valid
                cn0 = te.cn0_est_dbhz
                # measurement errors of the loops: code error x chip length, Doppler error x lambda
                from hyper_nav_gnss.receiver.acquisition import CHIP_LENGTH_CA_M
                from hyper_nav_gnss.receiver.tracking import dll_thermal_sigma_chips, epoch_correlation_factor
                pr = pr + te.code_err_chips * CHIP_LENGTH_CA_M
                obs.pseudorange_rate_mps = obs.pseudorange_rate_mps + te.freq_err_hz * lam
                # the DLL's thermal sigma at the estimated C/N0, grown for the loop error's correlation from one
                # epoch to the next (a narrow aided DLL's code error is one slow process across epochs, which
                # a filter takes as independent samples: epoch_correlation_factor, 2.25 at 0.1 Hz and 1 Hz).
                # Measured on the blackout's aided receiver without it (issue 23): the filter fixed on the
                # weak signals of the sheath's ramps, position ANEES 3.39 during (88 % of epochs in band)
                s_dll = dll_thermal_sigma_chips(np.nan_to_num(cn0, nan=0.0), c.tracking.loop.bn_dll_hz,
                                                c.tracking.loop.t_coh_s, c.tracking.loop.d_chips) * CHIP_LENGTH_CA_M
                s_dll = s_dll * epoch_correlation_factor(c.tracking.loop.bn_dll_hz, 1.0 / c.rate_hz)
                obs.pr_sigma_m = np.hypot(obs.pr_sigma_m, s_dll)
                # the loop's frequency error in the rate sigma (the Doppler is the NCO frequency averaged
                # over DOPPLER_AVG_S = 0.1 s): in phase lock sqrt(2) sigma_phi / (2 pi 0.1 s) [Hz] (the phase
                # error's change over the interval); out of it (FLL / pull-in) a third of the FLL's range
                # 1/(4 T). Without it the unaided receiver's rates after reacquisition (1-7 m/s off, seen)
                # went in with 0.05 m/s sigmas.
                from hyper_nav_gnss.receiver.tracking import pll_thermal_sigma_deg
                aided_ch = (te.tracking_flags & 16) > 0
                bn = np.where(aided_ch, c.tracking.loop.bn_pll_hz, trk.cfg_unaided.bn_pll_hz)
                tco = np.where(aided_ch, c.tracking.loop.t_coh_s, trk.cfg_unaided.t_coh_s)
                s_phi = np.deg2rad(pll_thermal_sigma_deg(np.nan_to_num(cn0, nan=0.0), bn, tco))
                from hyper_nav_sim.core.gnss.receiver_tracking import DOPPLER_AVG_S
                s_f = np.where(te.mode == 2, np.sqrt(2.0) * s_phi / (2 * np.pi * DOPPLER_AVG_S), 1.0 / (12.0 * tco))
                obs.rate_sigma_mps = np.hypot(obs.rate_sigma_mps, s_f * lam)
        else:
            obs = None
            te = None
            locked = np.zeros(0, bool)
        fix = None
        need = 3 + len({e.system for e, l in zip(ephs, locked) if l})
        if n and locked.sum() >= max(need, 4):
            idx = np.flatnonzero(locked)
            le = [ephs[i] for i in idx]
            sol = solve_pvt(le, obs.t_tag_s, pr[idx], obs.pr_sigma_m[idx], obs.pseudorange_rate_mps[idx],
                            obs.rate_sigma_mps[idx], iono_m=obs.iono_m[idx], tropo_m=obs.tropo_m[idx],
                            r0_e_m=None if r_prev is None else r_prev + v_prev * (t - t_prev))
            lat, lon, alt = earth.ecef_to_geodetic(sol.r_e_m)
            Cne = earth.C_n_e(lat, lon)
            P, Pv = sol.cov_pos_clk[:3, :3], sol.cov_vel_drift[:3, :3]
            fix = GnssFix(sol.r_e_m, sol.v_e_mps, float(lat), float(lon), float(alt), Cne.T @ sol.v_e_mps,
                          P, Cne.T @ P @ Cne, Pv, Cne.T @ Pv @ Cne, sol.clk_bias_m, sol.clk_drift_mps,
                          sol.isb_m, sol.dop, int(idx.size), [sat_ids[i] for i in idx],
                          float(np.sqrt(max(sol.cov_vel_drift[3, 3], 0.0))) if sol.cov_vel_drift is not None
                          else float("nan"))
            self.r_prev, self.v_prev, self.t_prev = sol.r_e_m, sol.v_e_mps, t
            self.last_fix = (float(t), fix)
        if trk is not None:
            trk.note_fix(float(t), fix is not None)
            # the receiver's clock-drift estimate for the aiding: the common mode of the aided channels'
            # NCO corrections in phase lock (clock steering of a deeply aided receiver); without it the
            # PVT's drift (noisy: +-0.5 m/s per epoch seen), held and growing in sigma while no fix
            cm = trk.common_mode_hz() if trk.external else None
            if cm is not None and self.drift_hat is not None:
                lam1 = C_MPS / CARRIER_HZ["G"]
                x, _ = self._drift_at(float(t))
                self.drift_hat = (float(t), x - lam1 * cm, 0.02 ** 2)     # from the PLLs: a few cm/s
                trk.shift_aided(cm)
            elif fix is not None and np.isfinite(fix.clk_drift_sigma_mps):
                # a clock filter on the PVT's drift (noisy: +-0.5 m/s per epoch seen): Kalman update
                r = max(fix.clk_drift_sigma_mps, 1e-3) ** 2
                if self.drift_hat is None:
                    self.drift_hat = (float(t), fix.clk_drift_mps, r)
                else:
                    x, s_d = self._drift_at(float(t))
                    g = s_d ** 2 / (s_d ** 2 + r)
                    self.drift_hat = (float(t), x + g * (fix.clk_drift_mps - x), (1 - g) * s_d ** 2)
        z = np.zeros(0)
        return GnssEpoch(
            float(t), t_g, t_g + clk_b[k] / C_MPS, sat_ids, [e.system for e in ephs],
            np.array([e.prn for e in ephs], int),
            pr if n else z, obs.pseudorange_rate_mps if n else z, obs.doppler_hz if n else z,
            obs.carrier_hz if n else z, cn0 if n else z, obs.el_rad if n else z, obs.az_rad if n else z,
            locked, obs.pr_sigma_m if n else z, obs.rate_sigma_mps if n else z,
            obs.iono_m if n else z, obs.tropo_m if n else z, fd_veh if n else z, fd_veh_rate if n else z,
            obs.geometric_rate_mps if n else z, ephs, eset, float(clk_b[k]), float(clk_d[k]),
            r_a[k], v_a[k], fix, obs.iono_true_m if n else z, obs.tropo_true_m if n else z,
            None if te is None else te.lock_time_s, None if te is None else te.tracking_flags,
            None if te is None else te.cn0_true_dbhz)


__all__ = ["GnssReceiverConfig", "GnssReceiverSim", "ReceiverRun", "GnssEpoch", "GnssFix", "gpst_from_date",
           "KLOBUCHAR_ALPHA_DEFAULT", "KLOBUCHAR_BETA_DEFAULT", "CARRIER_HZ"]
