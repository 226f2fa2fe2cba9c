"""LinCov of the configured INS filter along a reference trajectory.

Builds the matrices of ``core.lincov.linear`` from what the filter itself
declares, so the analysis is of *this* filter and not of a textbook one:

* the filter's own covariance: its frame's 9 x 9 error dynamics
  (``core.frames``) and its state blocks' self-dynamics, couplings and noises
  (``core.system_model``), discretised as the filter does (``discretize``),
  with the gyro rate-error inflation of ``blocks.nav``;
* its measurement models (``core.measurements``: ``GnssPosition``,
  ``GnssVelocity`` ...), evaluated on the reference state, their H mapped
  into the frame's error state as ``ErrorStateKF.model`` does;
* the truth (``core.lincov.truth``): y = [e_nav (9), d_v (n - 9), s (p)]
  with d_v = v_hat - P_v s the filter's block errors against the truth's
  values. With B_att, B_vel the body-axis couplings of the filter's blocks
  (d phi/dt += C B_att d_v, d dv/dt += C B_vel d_v, so a block value v
  stands for a gyro error B_att v and an accelerometer error -B_vel v) and
  E_g, E_a the truth's sensor errors per unit of s (``TruthModel.E``):

      d phi/dt = F9 (att) + C B_att d_v - C (E_g - B_att P_v) s - C n_g
      d dv/dt  = F9 (vel) + C B_vel d_v + C (E_a + B_vel P_v) s + C n_a
      d d_v/dt = A_nom d_v + (A_nom P_v - P_v A_s) s - P_v w_s
      d s/dt   = A_s s + w_s

  where A_nom is the nominal propagation of the block values the filter
  actually applies between updates (``Block.propagate``; a random-constant
  bias block keeps its value even when its error model has a finite tau),
  n_g, n_a the truth's white sensor noises and w_s the driving noises of
  the truth's Markov sources. The filter's own process noise enters only its
  own P_f (and so its gain), never the true error.

Residual = predicted - measured = H e + H_s s - v, with H_s the antenna
lever-arm error (pos: -C_b_n; vel: -C_b_n [w_nb x]) and, with a lever arm,
the truth's gyro error through the antenna velocity (-C_b_n [l x] (E_g -
B_att P_v)).

The error budget is by group (initial attitude / velocity / position, each
truth source, each white noise, each measurement noise): ``linear.LinCov``
propagates one covariance per group, their sum is the total. Linearised
about the reference (no gating: every measurement is taken).
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from ..attitude import skew
from ..frames import make_frame
from ..measurements import GnssPosition, GnssVelocity, ModelContext
from ..nav_state import NavState
from ..system_model import discretize, expm_taylor, system_model
from ..blocks.nav import Attitude
from .linear import LinCov
from .truth import TruthModel

INIT_GROUPS = ("initial attitude", "initial velocity", "initial position")
NAV = {"att": slice(0, 3), "vel": slice(3, 6), "pos": slice(6, 9)}


@dataclass(frozen=True)
class Reference:
    """The reference trajectory at the LinCov epochs t_s (K + 1,), t_s[0] the
    start: geodetic position, ENU velocity, C_b_n, body rate relative to ENU
    (rad/s) at each epoch, and the interval means of omega_ib_b (rad/s) and
    f_b (m/s^2) over (t_k-1, t_k] (K,), i.e. the exact IMU increments / dt."""
    t_s: np.ndarray
    lat_rad: np.ndarray
    lon_rad: np.ndarray
    alt_m: np.ndarray
    vel_enu_mps: np.ndarray
    C_b_n: np.ndarray
    omega_nb_b_radps: np.ndarray
    omega_ib_b_radps: np.ndarray
    f_b_mps2: np.ndarray

    def nav(self, k: int) -> NavState:
        return NavState(float(self.t_s[k]), float(self.lat_rad[k]), float(self.lon_rad[k]), float(self.alt_m[k]),
                        np.asarray(self.vel_enu_mps[k], float), np.asarray(self.C_b_n[k], float))


@dataclass(frozen=True)
class LooseGnss:
    """Loosely coupled GNSS fixes at ``rate_hz`` (epochs k / rate), except in
    ``outages_s`` windows [t0, t1): the filter's models ``GnssPosition`` /
    ``GnssVelocity``. ``pos_sigma_enu_m`` / ``vel_sigma_enu_mps`` is the
    truth's white noise; the filter's R is the fix's declared covariance,
    ``filter_*_sigma`` (default: the same). ``lever_arm_b_m`` the antenna
    lever arm the filter uses (its configured one)."""
    rate_hz: float
    pos_sigma_enu_m: np.ndarray
    vel_sigma_enu_mps: np.ndarray
    lever_arm_b_m: np.ndarray = field(default_factory=lambda: np.zeros(3))
    outages_s: tuple = ()
    filter_pos_sigma_enu_m: np.ndarray | None = None
    filter_vel_sigma_enu_mps: np.ndarray | None = None
    use_pos: bool = True
    use_vel: bool = True

    groups = ("GNSS position noise", "GNSS velocity noise")

    def due(self, t_s: float) -> bool:
        x = t_s * self.rate_hz
        if abs(x - round(x)) > 1e-6 or t_s <= 0:
            return False
        return not any(a <= t_s < b for a, b in self.outages_s)


@dataclass
class LinCovResult:
    """Per recorded epoch: variances by group of the ENU navigation errors
    (``var`` (T, G, 9): att rad^2, vel (m/s)^2, pos m^2, frame axes ENU),
    the filter's own variances (``filter_var`` (T, 9)) and the CPU time."""
    t_s: np.ndarray
    groups: tuple
    var: np.ndarray
    filter_var: np.ndarray
    cpu_s: float = 0.0
    n_updates: int = 0
    meta: dict = field(default_factory=dict)

    @property
    def total_var(self) -> np.ndarray:
        return self.var.sum(axis=1)

    def sigma(self, block: str) -> np.ndarray:
        """True 1-sigma per axis of att / vel / pos (T, 3)."""
        return np.sqrt(self.total_var[:, NAV[block]])

    def filter_sigma(self, block: str) -> np.ndarray:
        return np.sqrt(self.filter_var[:, NAV[block]])

    def share(self, block: str, k: int = -1) -> dict:
        """{group: its share of the block's summed variance at record k}."""
        v = self.var[k][:, NAV[block]].sum(axis=1)
        tot = v.sum()
        return {g: float(x / tot) if tot > 0 else 0.0 for g, x in zip(self.groups, v)}


class InsLinCov:
    """LinCov of the filter configured by ``cfg`` (a FilterConfig) against the
    truth ``truth`` (TruthModel) along ``ref`` (Reference), with the
    measurement schedules ``measurements`` (e.g. [LooseGnss(...)])."""

    def __init__(self, cfg, truth: TruthModel, ref: Reference, measurements=()):
        self.cfg, self.truth, self.ref = cfg, truth, ref
        self.meas = tuple(measurements)
        lay = cfg.layout
        for b in lay.value_blocks:
            if b.preprocess is not None:
                raise ValueError(f"LinCov: state block {b.name!r} pre-processes the IMU (elastic lever arm); "
                                 "not linearised here")
        self.layout = lay
        self.sys = system_model(cfg)
        self.n, self.nv, self.p = lay.dim, lay.value_dim, truth.dim
        self.N = self.n + self.p
        self.Pv = truth.carrier_map(lay)
        self.A_nom = self._nominal_dynamics()
        self.frame = make_frame(cfg, ref.nav(0))
        self._noise_groups()

    # ---- construction ----------------------------------------------------------------
    def _nominal_dynamics(self) -> np.ndarray:
        """A_nom of the block values: the derivative of each block's nominal
        propagation (``Block.propagate``, linear in the value) at dt -> 0."""
        A = np.zeros((self.nv, self.nv))
        h = 1e-6
        for b in self.layout.value_blocks:
            s = self.layout.value_sl(b.name)
            for j in range(b.size):
                e = np.zeros(b.size)
                e[j] = 1.0
                A[s, s.start + j] = (np.asarray(b.propagate(e, h, self.cfg), float) - e) / h
        return A

    def _noise_groups(self) -> None:
        """Continuous noise inputs of y per group: {group: (G_rows_fn, psd)}."""
        n, nv, N = self.n, self.nv, self.N
        self.groups = list(INIT_GROUPS)
        self.P0 = {}
        sig = self.truth.init_nav_sigma
        for g, sl in zip(INIT_GROUPS, (NAV["att"], NAV["vel"], NAV["pos"])):
            P = np.zeros((N, N))
            P[sl, sl] = np.diag(sig[sl] ** 2)
            self.P0[g] = P
        L = np.zeros((N, self.p))           # y = L s at the start (block errors -P_v s)
        L[9:n] = -self.Pv
        L[n:] = np.eye(self.p)
        self.markov_G = {}                  # group -> (N x k constant G, psd)
        self.white = {}                     # group -> (target rows, psd) via body
        for s in self.truth.sources:
            g = s.group
            if g not in self.groups:
                self.groups.append(g)
            if s.size:
                i = self.truth.sl(s.name)
                P0s = np.zeros((self.p, self.p))
                P0s[i, i] = np.diag(s.sigma**2)
                self.P0[g] = self.P0.get(g, 0.0) + L @ P0s @ L.T
                if s.markov:
                    G = np.zeros((N, s.size))
                    G[:, :] = L[:, i]
                    psd = 2.0 * s.sigma**2 / s.tau_s
                    old = self.markov_G.get(g)
                    self.markov_G[g] = (G, psd) if old is None else (np.hstack([old[0], G]),
                                                                     np.concatenate([old[1], psd]))
            elif s.enters == "process_noise" and s.sensor in ("gyro", "accel"):
                rows, sign = (NAV["att"], -1.0) if s.sensor == "gyro" else (NAV["vel"], 1.0)
                old = self.white.get(g, [])
                self.white[g] = old + [(rows, sign, s.sigma**2)]
        for m in self.meas:
            for g in m.groups:
                if g not in self.groups:
                    self.groups.append(g)

    def initial_filter_covariance(self) -> np.ndarray:
        P0 = self.cfg.initial_covariance()
        T = self._T(0)
        if T is None:
            return P0
        Ti = np.linalg.inv(T)
        return Ti @ P0 @ Ti.T

    def _T(self, k):
        """n x n transform of the filter's error state to the ENU convention at ref epoch k (None: identity)."""
        T9 = self.frame.to_enu(self.frame.nominal(self.ref.nav(k)), float(self.ref.t_s[k]))
        if T9 is None:
            return None
        T = np.eye(self.n)
        T[:9, :9] = T9
        return T

    # ---- one step ----------------------------------------------------------------------
    def _step_matrices(self, k: int, w_prev):
        """Phi_f, Q_f, Phi_y, {group: Q_y} and (B_att, E_g, C) over (t_k-1, t_k]."""
        ref, n, nv, p, N = self.ref, self.n, self.nv, self.p, self.N
        dt = float(ref.t_s[k] - ref.t_s[k - 1])
        nav = ref.nav(k - 1)
        x = self.frame.nominal(nav)
        w, f = ref.omega_ib_b_radps[k - 1], ref.f_b_mps2[k - 1]
        wdot = np.zeros(3) if w_prev is None else (w - w_prev) / dt
        F9, C = self.frame.error_dynamics(x, float(ref.t_s[k - 1]), f, w)
        F_f, G_f, qc_f = self.sys.matrices(F9, C, w, f, wdot)
        Phi_f, Q_f = discretize(F_f, G_f, qc_f, dt, self.sys.exact)
        if self.cfg.gyro_rate_error_pct > 0:
            q = Attitude.rate_error_q(self.cfg, w * dt, dt)
            a = self.layout.sl("att").start
            Q_f = Q_f.copy()
            Q_f[a:a + 3, a:a + 3] += q * np.eye(3)
        Fb, _, _ = self.sys.matrices(np.zeros((9, 9)), np.eye(3), w, f, wdot)
        B_att, B_vel = Fb[0:3, 9:n], Fb[3:6, 9:n]
        Eg, Ea = self.truth.E(w, f)
        Fy = np.zeros((N, N))
        Fy[:n, :n] = F_f
        Fy[9:n, 9:n] = self.A_nom
        if p:
            A_s = self.truth.A()
            Fy[0:3, n:] = -C @ (Eg - B_att @ self.Pv)
            Fy[3:6, n:] = C @ (Ea + B_vel @ self.Pv)
            Fy[9:n, n:] = self.A_nom @ self.Pv - self.Pv @ A_s
            Fy[n:, n:] = A_s
        Phi_y = expm_taylor(Fy * dt)
        Qy = {}
        for g, (G, psd) in self.markov_G.items():
            GQG = (G * psd) @ G.T
            Qy[g] = 0.5 * (Phi_y @ GQG @ Phi_y.T + GQG) * dt
        for g, parts in self.white.items():
            GQG = np.zeros((N, N))
            for rows, sign, psd in parts:
                M = sign * C
                GQG[rows, rows] += (M * psd) @ M.T
            Qy[g] = 0.5 * (Phi_y @ GQG @ Phi_y.T + GQG) * dt
        return Phi_f, Q_f, Phi_y, Qy, B_att, Eg, w

    def _measure(self, lc: LinCov, k: int, B_att, Eg) -> None:
        ref, lay, n = self.ref, self.layout, self.n
        t = float(ref.t_s[k])
        nav = ref.nav(k)
        T = self._T(k)
        lev_src = [s for s in self.truth.sources if s.enters == "measurement"]
        for m in self.meas:
            if not m.due(t):
                continue
            lever = np.asarray(m.lever_arm_b_m, float)
            ctx = ModelContext(lever, np.asarray(ref.omega_nb_b_radps[k], float))
            C = nav.C_b_n
            rows = []
            if m.use_pos:
                cov_t = np.diag(np.asarray(m.pos_sigma_enu_m, float) ** 2)
                fs = m.filter_pos_sigma_enu_m
                cov_f = cov_t if fs is None else np.diag(np.asarray(fs, float) ** 2)
                model = GnssPosition(t, nav.lat_rad, nav.lon_rad, nav.alt_m, cov_f)
                _, H, R = model.model(nav, lay, ctx)
                Hs = np.zeros((3, self.p))
                for s in lev_src:
                    Hs[:, self.truth.sl(s.name)] += -C
                rows.append((H, R, Hs, cov_t, m.groups[0]))
            if m.use_vel:
                cov_t = np.diag(np.asarray(m.vel_sigma_enu_mps, float) ** 2)
                fs = m.filter_vel_sigma_enu_mps
                cov_f = cov_t if fs is None else np.diag(np.asarray(fs, float) ** 2)
                model = GnssVelocity(t, nav.vel_enu_mps, cov_f)
                _, H, R = model.model(nav, lay, ctx)
                Hs = np.zeros((3, self.p))
                if self.p and np.any(lever != 0):
                    Hs += -C @ skew(lever) @ (Eg - B_att @ self.Pv)
                for s in lev_src:
                    Hs[:, self.truth.sl(s.name)] += -C @ skew(ref.omega_nb_b_radps[k])
                rows.append((H, R, Hs, cov_t, m.groups[1]))
            for H, R, Hs, cov_t, g in rows:
                H = np.array(H, float)
                if T is not None:
                    H[:, :9] = H[:, :9] @ T[:9, :9]
                Hy = np.hstack([H, Hs])
                lc.update(H, R, Hy, {g: cov_t})

    # ---- run ------------------------------------------------------------------------
    def run(self, record_every: int = 1, record_t_s=None) -> LinCovResult:
        """Propagate along the whole reference; record every ``record_every``
        epochs (or at the epochs nearest ``record_t_s``)."""
        import time
        cpu0 = time.process_time()
        ref = self.ref
        K = len(ref.t_s) - 1
        lc = LinCov(self.initial_filter_covariance(), self.groups, self.P0, n_filter=self.n)
        if record_t_s is not None:
            keep = set(int(np.argmin(np.abs(ref.t_s - t))) for t in np.atleast_1d(record_t_s))
        else:
            keep = set(range(0, K + 1, record_every)) | {K}
        ts, var, fvar = [], [], []

        def record(k):
            T = self._T(k)
            P = lc.P[:, :9, :9]
            Pf = lc.P_f[:9, :9]
            if T is not None:
                T9 = T[:9, :9]
                P = T9 @ P @ T9.T
                Pf = T9 @ Pf @ T9.T
            ts.append(float(ref.t_s[k]))
            var.append(np.diagonal(P, axis1=1, axis2=2).copy())
            fvar.append(np.diag(Pf).copy())

        if 0 in keep:
            record(0)
        w_prev = None
        for k in range(1, K + 1):
            Phi_f, Q_f, Phi_y, Qy, B_att, Eg, w_prev = self._step_matrices(k, w_prev)
            lc.predict(Phi_f, Q_f, Phi_y, Qy)
            self._measure(lc, k, B_att, Eg)
            if k in keep:
                record(k)
        return LinCovResult(np.array(ts), tuple(self.groups), np.array(var), np.array(fvar),
                            cpu_s=time.process_time() - cpu0, n_updates=lc.n_updates)
