"""EKF intensity update as an along-gradient pseudo-fix (ours; the
"tightly coupled" SITAN/SIMAN idea through the horizontal-fix interface).

Each magnetometer sample is one scalar measurement of the fusion filter's
full error state (seed 003 eq. 11 with the map's exact gradient at the
indicated position instead of a 2-state filter):

    z = F_map(r^) - m = g . dr + v,   var(v) = sigma^2 + (g_U sigma_h)^2

(g the horizontal gradient, g_U the vertical one times the nav altitude
sigma). A scalar update along u = g / |g| is exactly a horizontal fix at
r^ - u z / |g| whose EN covariance is sigma_v^2 / |g|^2 along u and
unbounded across it (``across_sigma_m``, 1e5 m by default: no information).

With ``vertical`` (default) the same is done in 3-D with the full gradient
(E, N, U): the fix is r^ - u3 z / |g3| with variance sigma^2 / |g3|^2 along
u3 = g3 / |g3| and unbounded in the plane across it, i.e. exactly the scalar
update z = g3 . dr + v of the fusion filter's position block, altitude
included. This matters: the field falls ~30 nT per km of height, so a
baro-aided altitude error of 1-3 m is 0.03-0.09 nT, as large as the 0.1 nT
map-error level; as extra noise of a horizontal fix it cannot be estimated
jointly with the barometer.
The fusion filter then gains exactly the measurement's information: no
second filter holds a copy of the prior, nothing is counted twice, and the
filter's own INS error model (velocity, tilt, biases, scale factors, the
turns) decides how the along-gradient information reaches the across-gradient
position.

Correlated map error (``map_error_corr_length_m`` L > 0): the map error
along the track is modelled as first-order Markov, d_k = a d_k-1 + w_k,
a = exp(-dt / tau), with tau = sqrt(pi/2) L / speed (the integral scale of
a Gaussian covariance of length L, which is the simulator's), and the
measurement differenced (Bryson-Henrikson):

    z'_k = z_k - a z~_k-1 = (1 - a) g . dr_k + w_k + ...

where z~_k-1 is the previous sample's residual re-evaluated at the current
estimate carried back by the INS displacement (trapezoid of the two
velocities), so the correction applied at k-1 is accounted for. The fix is
then r^ - u z' / ((1 - a) |g|) with along variance
(sigma^2 (1 - a^2) + sigma_n^2 (1 + a^2)) / ((1 - a)^2 |g|^2); sigma_n is
the white part, here the ``white_sigma_nT`` share of sigma.
"""
from __future__ import annotations

import numpy as np

from hyper_nav_aiding.geomag.core.geomag_map import GeomagMap
from hyper_nav_aiding.geomag.core.matching import LocalFrame, MagSample, MatchResult, NavPoint, gradient_frame_cov


class EkfIntensity:
    name = "EKF"

    def __init__(self, gmap: GeomagMap, params, field_sigma_nT: float, white_sigma_nT: float = 0.0):
        self.map = gmap
        self.p = params
        self.sigma_nT = field_sigma_nT
        self.white_nT = white_sigma_nT
        self.reset()

    def reset(self) -> None:
        self._prev = None        # (t_s, measured nT, nav velocity) of the previous sample

    def step(self, sample: MagSample, nav: NavPoint) -> MatchResult:
        f, g = self.map.total_and_gradient(nav.lat_rad, nav.lon_rad, nav.alt_m)
        g_h = g[:2]
        gn = float(np.linalg.norm(g_h))
        u = g_h / gn
        z = float(f) - sample.total_nT
        alt_var = nav.alt_var_m2 if np.isfinite(nav.alt_var_m2) else 0.0
        var_alt = g[2] ** 2 * alt_var
        speed = float(np.linalg.norm(np.asarray(nav.vel_enu_mps, float)[:2]))
        tau = np.sqrt(np.pi / 2.0) * self.p.map_error_corr_length_m / max(speed, 1.0)
        prev, self._prev = self._prev, (sample.t_s, sample.total_nT, np.asarray(nav.vel_enu_mps, float))
        if tau > 0.0 and prev is not None and 0.0 < sample.t_s - prev[0] <= 3.0 * tau:
            dt = sample.t_s - prev[0]
            a = float(np.exp(-dt / tau))
            disp = 0.5 * (prev[2][:2] + np.asarray(nav.vel_enu_mps, float)[:2]) * dt
            frame = LocalFrame(nav.lat_rad, nav.lon_rad, nav.alt_m)
            lat_p, lon_p = frame.to_geodetic(-disp)
            alt_p = nav.alt_m - 0.5 * (prev[2][2] + nav.vel_enu_mps[2]) * dt
            z_prev = float(self.map.total_nT(lat_p, lon_p, alt_p)) - prev[1]
            z_eff = (z - a * z_prev) / (1.0 - a)
            var = (self.sigma_nT**2 * (1.0 - a * a) + self.white_nT**2 * (1.0 + a * a)
                   + var_alt * (1.0 - a) ** 2) / (1.0 - a) ** 2
        else:
            z_eff = z
            var = self.sigma_nT**2 + var_alt
        frame = LocalFrame(nav.lat_rad, nav.lon_rad, nav.alt_m)
        if self.p.vertical:
            var -= var_alt                                  # the altitude error is in the state now
            g3n = float(np.linalg.norm(g))
            u3 = np.asarray(g, float) / g3n
            d = -u3 * z_eff / g3n
            lat, lon = frame.to_geodetic(d[:2])
            s3 = float(np.sqrt(var)) / g3n
            cov3 = s3**2 * np.outer(u3, u3) + self.p.across_sigma_m**2 * (np.eye(3) - np.outer(u3, u3))
            sig_h = float(np.sqrt(var)) / gn                # what it is worth horizontally, for the quality
            return MatchResult(sample.t_s, self.name, True, "", float(lat), float(lon), cov3[:2, :2].copy(),
                               alt_m=float(nav.alt_m + d[2]), cov_enu_m2=cov3, metric=z, iterations=1,
                               sequence_length=1, along_gradient_sigma_m=sig_h,
                               across_gradient_sigma_m=self.p.across_sigma_m, gradient_nt_per_km=gn * 1e3)
        sig_along = float(np.sqrt(var)) / gn
        lat, lon = frame.to_geodetic(-u * z_eff / gn)
        cov = gradient_frame_cov(g_h, sig_along, self.p.across_sigma_m)
        return MatchResult(sample.t_s, self.name, True, "", float(lat), float(lon), cov,
                           metric=z, iterations=1, sequence_length=1, along_gradient_sigma_m=sig_along,
                           across_gradient_sigma_m=self.p.across_sigma_m, gradient_nt_per_km=gn * 1e3)
