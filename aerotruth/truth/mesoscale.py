"""Mesoscale wind perturbations: a random-phase sum of plane waves whose horizontal
kinetic-energy spectrum follows Nastrom & Gage (1985).

Field (tangent-plane coordinates x east, y north, z up, metres; t seconds):

    (u, v)(x, y, z, t) = sum_j a_j (-sin th_j, cos th_j) cos(Phi_j)
    w(x, y, z, t)      = sum_i b_i cos(Phi_i)
    Phi_j = k_j (cos th_j (x - U t) + sin th_j (y - V t)) + m_j z + om_j t + phi_j

Each horizontal mode moves air across its wave vector, so (u, v) is non-divergent; the
vertical-velocity modes are an independent, much weaker field (they do not close
continuity: w is there for the aircraft's vertical air motion, not as a dynamical field).

Spectrum. Nastrom & Gage (1985, J. Atmos. Sci. 42, 950-960), from GASP airliner data at
9-14 km, found a horizontal kinetic-energy spectrum close to k^-3 at wavelengths of about
3000 to 500 km and k^-5/3 from about 500 km down to a few km. The usual fit to their
spectrum (Lindborg 1999, J. Fluid Mech. 388, 259) is

    E(k) = c3 k^-3 + c53 k^-5/3,   c3 ~= 3e-10 s^-2,  c53 ~= 9e-4 m^(4/3) s^-2,

with k in rad/m and the integral of E over k equal to (u'^2 + v'^2)/2. In km units
c3 = 3e-4 m^2 s^-2 km^-2, the figure often quoted as "a = 3e-4". Check: the two terms
are equal at k = (c3/c53)^(3/4), a wavelength of ~455 km, where NG85 see the
transition; each term is then ~1.3e5 m^3 s^-2. The mode amplitudes below
treat E as the isotropic 2-D spectrum (for power laws the 1-D along-track spectrum
differs from it only by an O(1) factor). With the default band 3000-4 km the
per-component RMS is ~6.5 m/s (of which ~1.9 m/s comes from wavelengths < 500 km).

Time: modes are advected by a steering wind (U, V) and each carries a random
frequency om_j ~ N(0, 1/tau(k)) with the eddy turnover time tau = (k^3 E(k))^-1/2, so
the pattern decorrelates in a frame moving with the steering wind (hours at 10 km,
about half a day at 1000 km). Vertical: m_j ~ N(0, 1/Lz), which gives each component a
Gaussian vertical correlation exp(-dz^2 / (2 Lz^2)).

Vertical velocity spectrum: equal variance per octave (E_w ~ k^-1) between 5 and 200 km,
scaled to a chosen RMS; observed w spectra are much flatter than u, v spectra
(Bacmeister et al. 1996, J. Geophys. Res. 101(D5), 9441).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

# Lindborg (1999) fit to the Nastrom & Gage (1985) spectrum, k in rad/m.
NG_C3 = 3.0e-10  # s^-2, coefficient of k^-3
NG_C53 = 9.0e-4  # m^(4/3) s^-2, coefficient of k^-5/3

_CHUNK = 2048  # points per block: bounds the (points x modes) work array to a few MB


def nastrom_gage_spectrum(
    k_rad_per_m,
    c3: float = NG_C3,
    c53: float = NG_C53,
    slope_large: float = -3.0,
    slope_small: float = -5.0 / 3.0,
) -> np.ndarray:
    """Horizontal kinetic-energy spectrum E(k) (m^3 s^-2) at wavenumber k (rad/m).

    E = c3 k^slope_large + c53 k^slope_small (Nastrom & Gage 1985; Lindborg 1999 fit).
    """
    k = np.asarray(k_rad_per_m, dtype=float)
    if np.any(~(k > 0)):
        raise ValueError("nastrom_gage_spectrum: k_rad_per_m must be > 0")
    return c3 * k**slope_large + c53 * k**slope_small


def _band_energy(k_lo: np.ndarray, k_hi: np.ndarray, c: float, slope: float) -> np.ndarray:
    """Integral of c k^slope from k_lo to k_hi (slope != -1)."""
    p = slope + 1.0
    return c * (k_hi**p - k_lo**p) / p


@dataclass(frozen=True)
class MesoscaleSpec:
    """Parameters of the mesoscale field (SI). `energy_scale` multiplies the NG85 spectrum;
    `rms_ms`, when given, rescales the horizontal modes to that per-component RMS instead."""

    c3: float = NG_C3
    c53: float = NG_C53
    slope_large: float = -3.0
    slope_small: float = -5.0 / 3.0
    energy_scale: float = 1.0
    rms_ms: float | None = None
    max_wavelength_m: float = 3.0e6
    min_wavelength_m: float = 4.0e3
    shells: int = 36
    directions: int = 16
    vertical_scale_m: float = 1500.0
    lifetime_factor: float = 1.0
    steering_ms: tuple[float, float] = (10.0, 0.0)
    w_rms_ms: float = 0.25
    w_max_wavelength_m: float = 2.0e5
    w_min_wavelength_m: float = 5.0e3
    w_modes: int = 48

    def __post_init__(self) -> None:
        positive = (
            "c3",
            "c53",
            "energy_scale",
            "max_wavelength_m",
            "min_wavelength_m",
            "vertical_scale_m",
            "lifetime_factor",
            "w_max_wavelength_m",
            "w_min_wavelength_m",
        )
        for name in positive:
            if not (getattr(self, name) > 0):
                raise ValueError(f"MesoscaleSpec.{name} must be > 0, got {getattr(self, name)!r}")
        if self.min_wavelength_m >= self.max_wavelength_m:
            raise ValueError("MesoscaleSpec: min_wavelength_m must be < max_wavelength_m")
        if self.w_min_wavelength_m >= self.w_max_wavelength_m:
            raise ValueError("MesoscaleSpec: w_min_wavelength_m must be < w_max_wavelength_m")
        for name in ("shells", "directions", "w_modes"):
            if int(getattr(self, name)) < 1:
                raise ValueError(f"MesoscaleSpec.{name} must be >= 1, got {getattr(self, name)!r}")
        if self.rms_ms is not None and not (self.rms_ms >= 0):
            raise ValueError(f"MesoscaleSpec.rms_ms must be >= 0 or None, got {self.rms_ms!r}")
        if not (self.w_rms_ms >= 0):
            raise ValueError(f"MesoscaleSpec.w_rms_ms must be >= 0, got {self.w_rms_ms!r}")
        if -1.0 in (self.slope_large, self.slope_small):
            raise ValueError("MesoscaleSpec: spectral slopes of exactly -1 are not supported")


class MesoscaleField:
    """One realization of the mesoscale field; evaluate with `wind_xy`.

    Attributes (arrays over modes): `kx, ky, kz` (rad/m), `omega` (rad/s, includes the
    steering advection), `phase` (rad), `amplitude` (modes x 3: u, v, w in m/s).
    `rms_ms` is the expected per-component RMS of u (and of v) in m/s.
    """

    def __init__(self, kx, ky, kz, omega, phase, amplitude, rms_ms: float, w_rms_ms: float):
        self.kx = np.ascontiguousarray(kx, dtype=float)
        self.ky = np.ascontiguousarray(ky, dtype=float)
        self.kz = np.ascontiguousarray(kz, dtype=float)
        self.omega = np.ascontiguousarray(omega, dtype=float)
        self.phase = np.ascontiguousarray(phase, dtype=float)
        self.amplitude = np.ascontiguousarray(amplitude, dtype=float)
        self.rms_ms = float(rms_ms)
        self.w_rms_ms = float(w_rms_ms)
        # rows multiply (x, y, z, t, 1): Phi = [x y z t 1] @ coef
        self._coef = np.ascontiguousarray(np.stack([self.kx, self.ky, self.kz, self.omega, self.phase]))

    @classmethod
    def draw(cls, spec: MesoscaleSpec, rng: np.random.Generator) -> MesoscaleField:
        """Draw mode wavenumbers, directions, phases and frequencies from `rng`."""
        n_sh, n_dir = int(spec.shells), int(spec.directions)
        k_edges = np.geomspace(2 * np.pi / spec.max_wavelength_m, 2 * np.pi / spec.min_wavelength_m, n_sh + 1)
        k_lo, k_hi = k_edges[:-1], k_edges[1:]
        shell_energy = spec.energy_scale * (
            _band_energy(k_lo, k_hi, spec.c3, spec.slope_large) + _band_energy(k_lo, k_hi, spec.c53, spec.slope_small)
        )
        # Each mode: KE = a^2/4 (u'^2+v'^2 = a^2/2), so a shell's n_dir modes carry its energy.
        a_shell = 2.0 * np.sqrt(shell_energy / n_dir)
        # wavenumber log-uniform inside its shell; directions stratified over [0, pi)
        u01 = rng.random((n_sh, n_dir))
        k = np.exp(np.log(k_lo)[:, None] + u01 * np.log(k_hi / k_lo)[:, None])
        theta = (rng.random((n_sh, 1)) + np.arange(n_dir)[None, :]) * (np.pi / n_dir)
        phase_h = rng.uniform(0.0, 2 * np.pi, (n_sh, n_dir))
        kz_h = rng.normal(0.0, 1.0 / spec.vertical_scale_m, (n_sh, n_dir))
        e_k = spec.energy_scale * nastrom_gage_spectrum(k, spec.c3, spec.c53, spec.slope_large, spec.slope_small)
        tau = spec.lifetime_factor / np.sqrt(k**3 * e_k)  # eddy turnover time, s
        om_h = rng.normal(0.0, 1.0, (n_sh, n_dir)) / tau
        amp_h = np.broadcast_to(a_shell[:, None], (n_sh, n_dir))
        rms = float(np.sqrt(np.sum(amp_h**2) / 4.0))  # per-component RMS of u (= of v)
        if spec.rms_ms is not None:
            scale = spec.rms_ms / rms if rms > 0 else 0.0
            amp_h = amp_h * scale
            rms = float(spec.rms_ms)
        kx_h, ky_h = (k * np.cos(theta)).ravel(), (k * np.sin(theta)).ravel()
        amp_h = amp_h.ravel()

        n_w = int(spec.w_modes)
        kw = np.exp(
            rng.uniform(np.log(2 * np.pi / spec.w_max_wavelength_m), np.log(2 * np.pi / spec.w_min_wavelength_m), n_w)
        )
        thw = rng.uniform(0.0, 2 * np.pi, n_w)
        phase_w = rng.uniform(0.0, 2 * np.pi, n_w)
        kz_w = rng.normal(0.0, 1.0 / spec.vertical_scale_m, n_w)
        e_kw = spec.energy_scale * nastrom_gage_spectrum(kw, spec.c3, spec.c53, spec.slope_large, spec.slope_small)
        om_w = rng.normal(0.0, 1.0, n_w) * np.sqrt(kw**3 * e_kw) / spec.lifetime_factor
        b = np.full(n_w, spec.w_rms_ms * np.sqrt(2.0 / n_w))  # sum b^2/2 = w_rms^2
        kx_w, ky_w = kw * np.cos(thw), kw * np.sin(thw)

        us, vs = spec.steering_ms
        kx = np.concatenate([kx_h, kx_w])
        ky = np.concatenate([ky_h, ky_w])
        omega = np.concatenate([om_h.ravel(), om_w]) - kx * us - ky * vs
        amplitude = np.zeros((kx.size, 3))
        th_full = theta.ravel()
        amplitude[: amp_h.size, 0] = -amp_h * np.sin(th_full)
        amplitude[: amp_h.size, 1] = amp_h * np.cos(th_full)
        amplitude[amp_h.size :, 2] = b
        return cls(
            kx,
            ky,
            np.concatenate([kz_h.ravel(), kz_w]),
            omega,
            np.concatenate([phase_h.ravel(), phase_w]),
            amplitude,
            rms,
            spec.w_rms_ms,
        )

    def wind_xy(self, x_m, y_m, z_m, t_s) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """(u, v, w) in m/s at tangent-plane points (x east, y north, z up; m) and times (s).

        Inputs broadcast together; outputs have the broadcast shape.
        """
        x, y, z, t = np.broadcast_arrays(*(np.asarray(a, dtype=float) for a in (x_m, y_m, z_m, t_s)))
        shape = x.shape
        x, y, z, t = (a.reshape(-1) for a in (x, y, z, t))
        out = np.empty((x.size, 3))
        for s in range(0, x.size, _CHUNK):
            sl = slice(s, s + _CHUNK)
            pts = np.stack([x[sl], y[sl], z[sl], t[sl], np.ones(x[sl].size)], axis=1)
            ph = pts @ self._coef
            np.cos(ph, out=ph)
            out[sl] = ph @ self.amplitude
        return out[:, 0].reshape(shape), out[:, 1].reshape(shape), out[:, 2].reshape(shape)

    def wind_point(self, x_m: float, y_m: float, z_m: float, t_s: float) -> tuple[float, float, float]:
        """(u, v, w) m/s at one point: the fast path of `wind_xy` for scalars."""
        ph = np.array([x_m, y_m, z_m, t_s, 1.0]) @ self._coef
        np.cos(ph, out=ph)
        u, v, w = (ph @ self.amplitude).tolist()
        return u, v, w
