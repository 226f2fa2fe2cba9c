"""Gravitation in the LCI frame (seed 001 eqs. 7-10) and a WGS-84 normal-gravity option.

The LCI frame is inertial, so the mechanization (eq. 6) needs the
*gravitational* acceleration (mass attraction only, no centrifugal term).
Seed 001 eqs. 7-10 (symbols lost in extraction, reconstructed from the
launch-vehicle literature they cite, e.g. Chen Kejun, "Ballistic missile
trajectory", and Zhang et al. [12]):

    g_a    = g_r' r0 + g_we w0                                      (7)
    g_r'   = -mu / r^2 [1 + J (a_e / r)^2 (1 - 5 sin^2 phi)]        (8)
    g_we   = -2 mu / r^2 J (a_e / r)^2 sin phi                      (9)
    r_geo  = R0_a + r_a,  r0 = r_geo / r,  r = |r_geo|,
    sin phi = r0 . w0   (phi geocentric latitude)                   (10)

with mu = GM, J = 3/2 J2, a_e the equatorial radius and w0 the unit Earth
spin axis expressed in LCI (constant: the frame is inertial). This is the
exact gradient of the J2 potential mu/r [1 - J2/2 (a_e/r)^2 (3 sin^2 phi - 1)].

``gravity_normal_a`` is the option for consistency tests against the
project's truth (hyper_nav_sim Trajectory), which uses the WGS-84 normal
gravity of ``core.earth.gravity_n`` (Somigliana + 2nd-order free-air
correction; this is gravitation + centrifugal). Gravitation in LCI is then
    G_a = C_e_a(t) [C_n_e g_n + omega_ie x (omega_ie x r_e)].
The two models differ by up to ~1e-4 m/s^2 (measured in the tests), which
integrates to metres over minutes, so the truth-reproduction tests use the
normal-gravity option while J2 stays the default of the navigator.
"""
from __future__ import annotations

import math

import numpy as np

from hyper_nav_gnss import earth
from .frames import LaunchFrame, C_n_e_vec

GM_M3PS2 = earth.GM_M3PS2
A_E_M = earth.A_M
J2 = 1.082629821313e-3          # WGS-84 / EGM96 (from C20 = -4.84166774985e-4 * sqrt(5))


def gravity_j2_a(r_a_m, frame: LaunchFrame):
    """J2 gravitation in LCI [m/s^2] at LCI position(s) r_a_m (..., 3), eqs. 7-10."""
    r_geo = np.asarray(r_a_m, float) + frame.R0_a_m
    w0 = frame.spin_axis_a
    if r_geo.ndim == 1:        # scalar fast path for the per-epoch loop (~5x faster)
        x, y, z = r_geo.tolist()
        wx, wy, wz = w0.tolist()
        r2 = x * x + y * y + z * z
        r = math.sqrt(r2)
        sin_phi = (x * wx + y * wy + z * wz) / r
        k = 1.5 * J2 * A_E_M**2 / r2
        g_r = -GM_M3PS2 / r2 * (1.0 + k * (1.0 - 5.0 * sin_phi * sin_phi)) / r
        g_w = -2.0 * GM_M3PS2 / r2 * k * sin_phi
        return np.array([g_r * x + g_w * wx, g_r * y + g_w * wy, g_r * z + g_w * wz])
    r2 = np.sum(r_geo * r_geo, axis=-1)
    r = np.sqrt(r2)
    sin_phi = (r_geo @ w0) / r
    J = 1.5 * J2
    k = J * A_E_M**2 / r2
    g_r = -GM_M3PS2 / r2 * (1.0 + k * (1.0 - 5.0 * sin_phi**2))
    g_w = -2.0 * GM_M3PS2 / r2 * k * sin_phi
    return (g_r / r)[..., None] * r_geo + g_w[..., None] * w0


def gravity_gradient_a(r_a_m, frame: LaunchFrame):
    """d g_a / d r_a (3x3, s^-2) of the central term, mu / r^3 (3 r0 r0^T - I).

    The J2 part changes the gradient by ~1e-3 relative and is neglected here,
    as in the error models of seed 001 eq. 85 and the literature it follows."""
    r_geo = np.asarray(r_a_m, float) + frame.R0_a_m
    r = np.linalg.norm(r_geo)
    u = r_geo / r
    return GM_M3PS2 / r**3 * (3.0 * np.outer(u, u) - np.eye(3))


def gravity_normal_a(r_a_m, t_s, frame: LaunchFrame):
    """WGS-84 normal gravity (core.earth) minus centrifugal, i.e. gravitation,
    in LCI at LCI position(s) r_a_m and time(s) t_s. Same model as the truth."""
    if np.ndim(r_a_m) == 1 and np.ndim(t_s) == 0:
        return _gravity_normal_a_scalar(np.asarray(r_a_m, float), float(t_s), frame)
    r_e = frame.lci_position_to_ecef(r_a_m, t_s)
    lat, lon, alt = earth.ecef_to_geodetic(r_e)
    g_n = earth.gravity_n(lat, alt)
    g_e = np.einsum("...ij,...j->...i", C_n_e_vec(lat, lon), g_n)
    w = np.array([0.0, 0.0, earth.OMEGA_IE_RADPS])
    G_e = g_e + np.cross(w, np.cross(w, r_e))
    return np.einsum("...ij,...j->...i", frame.C_e_a(t_s), G_e)


def _gravity_normal_a_scalar(r_a_m, t_s, frame: LaunchFrame):
    """Scalar version of :func:`gravity_normal_a` with math-module arithmetic
    (numpy on 3-vectors costs ~1 ms per call here, this ~40 us)."""
    W = earth.OMEGA_IE_RADPS
    ang = W * (t_s - frame.t0_s)
    ca, sa = math.cos(ang), math.sin(ang)
    xt, yt, z = (frame.C_t_a.T @ (r_a_m + frame.R0_a_m)).tolist()     # LECI
    x, y = ca * xt + sa * yt, -sa * xt + ca * yt                     # ECEF = Rz(-ang) r_t
    # geodetic latitude/height by the fixed-point iteration of earth.ecef_to_geodetic
    e2, a = earth.E2, earth.A_M
    p = math.hypot(x, y)
    lon = math.atan2(y, x)
    lat = math.atan2(z, p * (1.0 - e2))
    for _ in range(6):
        sl = math.sin(lat)
        r_n = a / math.sqrt(1.0 - e2 * sl * sl)
        alt = p / math.cos(lat) - r_n
        lat = math.atan2(z, p * (1.0 - e2 * r_n / (r_n + alt)))
    sl, cl = math.sin(lat), math.cos(lat)
    r_n = a / math.sqrt(1.0 - e2 * sl * sl)
    alt = p / cl - r_n
    g = -float(earth.gravity_n(lat, alt)[2])                         # magnitude, along -up
    so, co = math.sin(lon), math.cos(lon)
    # G_e = -g up_e + centrifugal-removal omega x (omega x r) = -W^2 (x, y, 0)
    Gx = -g * cl * co - W * W * x
    Gy = -g * cl * so - W * W * y
    Gz = -g * sl
    # back to LECI then LCI
    G_t = np.array([ca * Gx - sa * Gy, sa * Gx + ca * Gy, Gz])
    return frame.C_t_a @ G_t


def make_gravity(model, frame: LaunchFrame):
    """Gravity callable g(r_a_m, t_s) -> g_a for the mechanization.

    model: "j2" (default, eqs. 7-10), "normal" (WGS-84 normal gravity as the
    truth uses it), "none" (zero, for analytic motion tests) or any callable
    with that signature (returned unchanged)."""
    if callable(model):
        return model
    if model == "j2":
        return lambda r_a_m, t_s: gravity_j2_a(r_a_m, frame)
    if model == "normal":
        return lambda r_a_m, t_s: gravity_normal_a(r_a_m, t_s, frame)
    if model == "none":
        return lambda r_a_m, t_s: np.zeros(3)
    raise ValueError(f"unknown gravity model {model!r}; use 'j2', 'normal', 'none' or a callable")
