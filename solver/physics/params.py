"""Physical parameters of the ball-rim system (paper Table 1) and their validation.

A :class:`Params` is an immutable value. Compiled kernels do not take the object; they
take the flat ``float64`` vector returned by :meth:`Params.as_array`, indexed by the
``P_*`` constants of this module.
"""

from __future__ import annotations

import dataclasses
import math

import numpy as np

# Layout of the flat parameter vector handed to compiled kernels.
P_R_BALL = 0  # r   [m]
P_R_RIM = 1  # R   [m]
P_A = 2  # a   [m]
P_M = 3  # m   [kg]
P_J = 4  # j   [-]
P_MU = 5  # mu  [-] (inf: never slips)
P_G = 6  # g   [m/s^2]
P_K_R = 7  # k_r [1/s]
P_K_D = 8  # k_d [1/s]
P_RHO = 9  # rho = r + a [m]
N_PARAMS = 10

UNITS = {
    "r": "m",
    "R": "m",
    "a": "m",
    "m": "kg",
    "j": "1",
    "mu": "1",
    "g": "m s-2",
    "k_r": "s-1",
    "k_d": "s-1",
}

LONG_NAMES = {
    "r": "radius of the ball",
    "R": "major radius of the rim",
    "a": "minor radius of the rim",
    "m": "mass of the ball",
    "j": "dimensionless moment of inertia of the ball",
    "mu": "Coulomb friction coefficient",
    "g": "gravitational acceleration",
    "k_r": "rolling-resistance rate C_r/(j m R^2)",
    "k_d": "drilling-resistance rate C_d/(j m R^2)",
}


@dataclasses.dataclass(frozen=True)
class Params:
    """Parameters of the ball and the rim, SI units (defaults: paper Table 1).

    Attributes
    ----------
    r : radius of the ball [m]
    R : major radius of the rim (torus) [m]
    a : minor radius of the rim (torus) [m]
    m : mass of the ball [kg]
    j : dimensionless moment of inertia, J = j m r^2 (2/3 for a thin shell) [-]
    mu : Coulomb friction coefficient [-]; ``inf`` means the ball never slips
    g : gravitational acceleration [m/s^2]
    k_r : rolling-resistance rate C_r/(j m R^2) of (83) [1/s]: the rate of omega1 and omega3 in the
        rolling equations (83) as printed (rimroll's reading; :func:`moment_normalised` gives the
        alternative one)
    k_d : drilling-resistance rate C_d/(j m R^2) of (83) [1/s]: the rate of omega2 in (83)

    Raises
    ------
    ValueError
        If a value is outside its allowed range; the message names the parameter,
        the value and the range.
    """

    r: float = 0.12
    R: float = 0.225
    a: float = 0.01
    m: float = 0.6
    j: float = 2.0 / 3.0
    mu: float = 1.0
    g: float = 9.81
    k_r: float = 0.0
    k_d: float = 0.0

    def __post_init__(self):
        for name in ("r", "R", "a", "m", "j", "mu", "g", "k_r", "k_d"):
            value = getattr(self, name)
            if isinstance(value, bool) or not isinstance(value, (int, float, np.floating, np.integer)):
                raise ValueError(f"parameter {name}={value!r} must be a real number")
            object.__setattr__(self, name, float(value))
        for name in ("r", "R", "a", "m", "g"):
            _require(name, getattr(self, name), math.isfinite(getattr(self, name)) and getattr(self, name) > 0,
                     "a positive finite number")
        _require("j", self.j, math.isfinite(self.j) and self.j > 0, "0 < j < inf")
        _require("mu", self.mu, not math.isnan(self.mu) and self.mu >= 0, "0 <= mu <= inf")
        for name in ("k_r", "k_d"):
            _require(name, getattr(self, name), math.isfinite(getattr(self, name)) and getattr(self, name) >= 0,
                     "a finite rate >= 0 [1/s]")
        if not self.rho < self.R:
            raise ValueError(
                f"geometry rho = r + a = {self.rho!r} m must be < R = {self.R!r} m "
                "so that R - rho*cos(beta) > 0 for every beta"
            )

    @property
    def rho(self) -> float:
        """Distance from the ball's centre to the rim's middle circle, r + a [m]."""
        return self.r + self.a

    @property
    def rolling_only(self) -> bool:
        """True when mu is infinite: the friction cone (39) is never left."""
        return math.isinf(self.mu)

    @property
    def dissipative(self) -> bool:
        """True when a contact moment (83) removes energy (k_r > 0 or k_d > 0)."""
        return self.k_r > 0 or self.k_d > 0

    def replace(self, **changes) -> Params:
        """A copy with some values changed (validated again)."""
        return dataclasses.replace(self, **changes)

    def as_dict(self) -> dict[str, float]:
        """The nine defining values, keyed by name."""
        return dataclasses.asdict(self)

    def as_array(self) -> np.ndarray:
        """Flat float64 vector for compiled kernels, indexed by the ``P_*`` constants."""
        out = np.empty(N_PARAMS)
        out[P_R_BALL] = self.r
        out[P_R_RIM] = self.R
        out[P_A] = self.a
        out[P_M] = self.m
        out[P_J] = self.j
        out[P_MU] = self.mu
        out[P_G] = self.g
        out[P_K_R] = self.k_r
        out[P_K_D] = self.k_d
        out[P_RHO] = self.rho
        return out

    @classmethod
    def from_rho_over_R(cls, rho_over_R: float, **others) -> Params:
        """Params with R and a at their given (default: Table 1) values and rho = rho_over_R * R.

        The ball radius follows as r = rho - a; it must stay positive.
        """
        R = others.pop("R", cls.R)
        a = others.pop("a", cls.a)
        rho = float(rho_over_R) * R
        if not (0 < rho_over_R < 1):
            raise ValueError(f"parameter rho_over_R={rho_over_R!r} must satisfy 0 < rho_over_R < 1")
        r = rho - a
        if not r > 0:
            raise ValueError(
                f"parameter rho_over_R={rho_over_R!r} gives ball radius r = rho - a = {r:.4g} m; "
                f"rho_over_R must be > a/R = {a / R:.4g}"
            )
        return cls(r=r, R=R, a=a, **others)


def _require(name: str, value: float, ok: bool, allowed: str) -> None:
    if not ok:
        raise ValueError(f"parameter {name}={value!r} is out of range: allowed {allowed}")


def moment_normalised(p: Params) -> Params:
    """The alternative reading of the dissipation (82)-(83): the same Params with the rates of (83)
    that follow when k_r, k_d are taken as the paper labels them, C_r/(j m R^2), C_d/(j m R^2).

    rimroll's reading (the default, used everywhere else) takes k_r and k_d as the rates of the
    rolling equations (83) as printed, -k_r omega1, -k_d omega2, -k_r omega3; the contact moment
    M_C of (82) is then -((1+j) m r^2 k_r omega1, j m r^2 k_d omega2, (1+j) m r^2 k_r omega3)
    (docs/outcome-studies.md#scenes). Read instead with C_r = k_r j m R^2 and C_d = k_d j m R^2, the
    moment (82) added to the Euler equation (25) under the rolling constraint gives the rates
    C_r/((1+j) m r^2) = k_r j R^2/((1+j) r^2) and C_d/(j m r^2) = k_d R^2/r^2: (1+j) in the rolling
    components and r for R. The returned Params carries those rates as k_r and k_d, so the engine,
    the slipping phases and a result file all use and record the rates actually simulated.
    """
    return p.replace(k_r=p.k_r * p.j * p.R**2 / ((1.0 + p.j) * p.r**2), k_d=p.k_d * p.R**2 / p.r**2)
