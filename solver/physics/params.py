"""Physical parameters of the ball-rim system (paper Table 1) and their validation.

A ``Params`` is an immutable value. Compiled kernels do not take the object; they
take the flat ``float64`` vector returned by ``Params.as_array``, indexed by the
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
P_C_R = 10  # c_r [m]: Coulomb rolling-resistance arm (solver.physics.resistance)
P_C_D = 11  # c_d [m]: Coulomb drilling-resistance contact length (solver.physics.resistance)
P_RHO_AIR = 12  # rho_air [kg/m^3] (0: no air; solver.physics.air)
P_C_DRAG = 13  # C_D [-]: drag coefficient of the ball (solver.physics.air)
N_PARAMS = 14


@dataclasses.dataclass(frozen=True)
class Range:
    """The allowed values of a real number: ``low`` and ``high``, each included unless ``*_open``
    (``high=inf`` included allows inf), optionally integers only. ``text`` states the range in a
    message (``{name}`` stands for the value's name); without it the bounds are written out."""

    low: float = -math.inf
    high: float = math.inf
    low_open: bool = False
    high_open: bool = False
    integer: bool = False
    text: str = ""

    def contains(self, value) -> bool:
        if self.integer and (isinstance(value, bool) or not isinstance(value, (int, np.integer))):
            return False
        v = float(value)
        if math.isnan(v):
            return False
        above = v > self.low if self.low_open else v >= self.low
        below = v < self.high if self.high_open else v <= self.high
        return above and below

    def describe(self, name: str) -> str:
        """E.g. ``0 < j < inf``, ``an integer 1 <= n_beta <= 100000``."""
        if self.text:
            return self.text.format(name=name)
        low, high = "<" if self.low_open else "<=", "<" if self.high_open else "<="
        text = f"{_number(self.low)} {low} {name} {high} {_number(self.high)}"
        return ("an integer " if self.integer else "") + text


def _number(x: float) -> str:
    if math.isinf(x):
        return "inf" if x > 0 else "-inf"
    if x == int(x) and abs(x) < 1e6:
        return str(int(x))
    return f"{x:g}".replace("e+", "e")


@dataclasses.dataclass(frozen=True)
class Quantity:
    """One physical parameter, declared once: CF units, long_name (of a coordinate, when a study
    sweeps it), a one-line doc (``study info``) and its allowed ``Range``."""

    name: str
    units: str
    long_name: str
    range: Range
    doc: str


MAX_MAGNITUDE = 1e12
"""Largest magnitude of a finite physical parameter: far beyond any physical use, and low enough that
the equations' products of parameters and rates stay inside floating point (j = 1e308 overflowed)."""
_POSITIVE = Range(0.0, MAX_MAGNITUDE, low_open=True, high_open=True, text="a positive number below 1e12")
_RATE = Range(0.0, MAX_MAGNITUDE, high_open=True, text="a rate >= 0 and below 1e12 [1/s]")
_RATE_83 = "rate C_{}/(j m R^2) of (83)"
_LENGTH = Range(0.0, MAX_MAGNITUDE, high_open=True, text="a length >= 0 and below 1e12 [m]")
_DENSITY = Range(0.0, MAX_MAGNITUDE, high_open=True, text="a density >= 0 and below 1e12 [kg/m^3]")

QUANTITIES = {q.name: q for q in (
    Quantity("r", "m", "radius of the ball", _POSITIVE, "radius of the ball"),
    Quantity("R", "m", "major radius of the rim", _POSITIVE, "major radius of the rim (torus)"),
    Quantity("a", "m", "minor radius of the rim", _POSITIVE, "minor radius of the rim (tube)"),
    Quantity("m", "kg", "mass of the ball", _POSITIVE, "mass of the ball"),
    Quantity("j", "1", "dimensionless moment of inertia of the ball, J = j m r^2",
             _POSITIVE, "moment of inertia J = j m r^2"),
    Quantity("mu", "1", "Coulomb friction coefficient", Range(0.0, math.inf),
             "Coulomb friction coefficient (inf: never slips)"),
    Quantity("g", "m s-2", "gravitational acceleration", _POSITIVE, "gravitational acceleration"),
    Quantity("k_r", "s-1", "rolling-resistance " + _RATE_83.format("r"), _RATE,
             "rolling-resistance rate, paper (83)"),
    Quantity("k_d", "s-1", "drilling-resistance " + _RATE_83.format("d"), _RATE,
             "drilling-resistance rate, paper (83)"),
    Quantity("c_r", "m", "Coulomb rolling-resistance arm: moment c_r F2 against the rolling rotation", _LENGTH,
             "Coulomb rolling resistance, moment -c_r F2 omega_t/|omega_t| (0: off)"),
    Quantity("c_d", "m", "Coulomb drilling-resistance contact length: moment c_d F2 against the spin omega2",
             _LENGTH, "Coulomb drilling resistance, moment -c_d F2 sign(omega2) (0: off)"),
    Quantity("rho_air", "kg m-3", "density of the air (quadratic drag on the ball; 0: no air)", _DENSITY,
             "air density of the drag -1/2 rho_air C_D pi r^2 |v| v (0: no air; air: 1.2)"),
    Quantity("C_D", "1", "drag coefficient of the ball", _POSITIVE, "drag coefficient of the ball (air drag)"),
    # not a field of Params: Params.from_rho_over_R(rho_over_R, ...) sets r = rho_over_R R - a
    Quantity("rho_over_R", "1", "ratio rho/R of the ball centre's distance from the rim's middle circle to "
                                "the rim's major radius (R and a fixed, r = rho - a)",
             Range(0.0, 1.0, low_open=True, high_open=True), "rho/R with R and a fixed (r = rho - a)"),
)}
"""The physical parameters: the fields of ``Params``, then ``rho_over_R``. ``Params``
validates with these ranges; the study layer's setting table takes their units, names and ranges
from here."""

UNITS = {name: q.units for name, q in QUANTITIES.items()}
LONG_NAMES = {name: q.long_name for name, q in QUANTITIES.items()}


def check(name: str, value) -> None:
    """ValueError naming the parameter, the value and the allowed range when ``value`` is outside
    the range of ``QUANTITIES``."""
    rule = QUANTITIES[name].range
    if not rule.contains(value):
        raise ValueError(f"parameter {name}={value!r} is out of range: allowed {rule.describe(name)}")


@dataclasses.dataclass(frozen=True)
class Params:
    """Parameters of the ball and the rim, SI units (defaults: paper Table 1); the units, names and
    allowed ranges of the fields are declared in ``QUANTITIES``.

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
        rolling equations (83) as printed (rimroll's reading; ``moment_normalised`` gives the
        alternative one)
    k_d : drilling-resistance rate C_d/(j m R^2) of (83) [1/s]: the rate of omega2 in (83)
    c_r : Coulomb rolling-resistance arm [m]: the moment -c_r F2 omega_t/|omega_t| against the
        rolling components omega_t = (omega1, 0, omega3) (``solver.physics.resistance``; 0: off)
    c_d : Coulomb drilling-resistance contact length [m]: the moment -c_d F2 sign(omega2) about the
        normal n2 (0: off)
    rho_air : density of the air [kg/m^3]: quadratic drag -1/2 rho_air C_D pi r^2 |v| v on the
        centre, on the rim and in the flight after separation (``solver.physics.air``); 0 (the
        default): no air, as in the paper; 1.2 for air at 20 C
    C_D : drag coefficient of the ball [-] (0.5: a sphere at the Reynolds numbers of a shot);
        used only with rho_air > 0

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
    c_r: float = 0.0
    c_d: float = 0.0
    rho_air: float = 0.0
    C_D: float = 0.5

    def __post_init__(self):
        for name in FIELDS:
            value = getattr(self, name)
            if isinstance(value, bool) or not isinstance(value, (int, float, np.floating, np.integer)):
                raise ValueError(f"parameter {name}={value!r} must be a real number")
            object.__setattr__(self, name, float(value))
        for name in FIELDS:
            check(name, getattr(self, name))
        for name in ("c_r", "c_d"):
            if not getattr(self, name) < self.r:
                raise ValueError(f"geometry: parameter {name}={getattr(self, name)!r} m must be < r = {self.r!r} m "
                                 "(the Coulomb resistance's arm lies within the ball's contact, a fraction of a mm)")
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
        """True when a term removes energy: a contact moment (83) (k_r > 0 or k_d > 0), a Coulomb
        resistance (c_r > 0 or c_d > 0) or air drag (rho_air > 0)."""
        return any(getattr(self, name) > 0 for name in DISSIPATION_KEYS)

    def replace(self, **changes) -> Params:
        """A copy with some values changed (validated again)."""
        return dataclasses.replace(self, **changes)

    def as_dict(self) -> dict[str, float]:
        """The defining values (``FIELDS``), keyed by name."""
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
        out[P_C_R] = self.c_r
        out[P_C_D] = self.c_d
        out[P_RHO_AIR] = self.rho_air
        out[P_C_DRAG] = self.C_D
        return out

    @classmethod
    def from_rho_over_R(cls, rho_over_R: float, **others) -> Params:
        """Params with R and a at their given (default: Table 1) values and rho = rho_over_R * R.

        The ball radius follows as r = rho - a; it must stay positive.
        """
        R = others.pop("R", cls.R)
        a = others.pop("a", cls.a)
        check("rho_over_R", rho_over_R)
        rho = float(rho_over_R) * R
        r = rho - a
        if not r > 0:
            raise ValueError(
                f"parameter rho_over_R={rho_over_R!r} gives ball radius r = rho - a = {r:.4g} m; "
                f"rho_over_R must be > a/R = {a / R:.4g}"
            )
        return cls(r=r, R=R, a=a, **others)


FIELDS = tuple(f.name for f in dataclasses.fields(Params))
"""The defining values of ``Params``, in order."""
DISSIPATION_KEYS = ("k_r", "k_d", "c_r", "c_d", "rho_air")
"""The parameters that switch on a dissipative term (0: off): a conservative run has them all 0."""
TERM_KEYS = (*DISSIPATION_KEYS, "C_D")
"""Every parameter of a term beyond the conservative equations (C_D acts only with rho_air > 0): what a
study that runs no such term ignores."""
ACTS_ONLY_WITH = {"C_D": "rho_air"}
"""A parameter that has no effect while another one is 0 (the drag coefficient without air): a figure's
title does not list it then."""
if FIELDS != tuple(QUANTITIES)[: len(FIELDS)]:
    raise ImportError(f"QUANTITIES must declare every field of Params, in order: {FIELDS}")


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
