"""A basketball shot from the release to the net: flight, impacts with the ring and the board, the end.

The public facade of the shot model (docs/shot-api.md, docs/shots.md). Units: SI, angles in rad,
spins in 1/s (rad/s). Frame: origin at the centre of the ring, z up (the rim plane z = 0 holds the
centre circle of the ring's tube), x from the shooter towards the board; the release point of the
ball's centre is at x = -distance, y = lateral, z = -height.

    from rimroll.solver import Params, shots
    res = shots.simulate_shots({"speed": v, "angle": theta}, shots.params_for("paper"), shots.Contact())
"""

from __future__ import annotations

import math
from typing import NamedTuple

import numpy as np

from rimroll.solver._arguments import real_number
from rimroll.solver.physics.params import Params
from rimroll.solver.physics.shot_geometry import GEOMETRIES, board_of, ring_of

__all__ = ["RELEASE", "GEOMETRIES", "OUTCOME_MEANINGS", "STATUS_MEANINGS", "FIRST_CONTACT_MEANINGS", "Contact",
           "params_for", "board_x", "simulate_shots", "trace_shot", "speed_to_reach"]


class ReleaseKey(NamedTuple):
    """One release key: its default (None: required), units, allowed closed range [low, high] and meaning."""

    default: float | None
    units: str
    low: float
    high: float
    doc: str


RELEASE = {
    "speed": ReleaseKey(None, "m s-1", 0.0, 50.0, "speed of the ball's centre at the release (> 0)"),
    "angle": ReleaseKey(None, "rad", -math.pi / 2, math.pi / 2, "elevation of the release velocity"),
    "distance": ReleaseKey(4.19, "m", 0.0, 30.0, "horizontal distance from the release point of the ball's "
                           "centre to the hoop's axis (> 0; 4.19: a free throw)"),
    "height": ReleaseKey(0.92, "m", -5.0, 5.0, "height of the rim plane above the release point "
                         "(0.92: a 3.05 m ring, a release at 2.13 m)"),
    "lateral": ReleaseKey(0.0, "m", -15.0, 15.0, "sideways offset of the release (+y: the shooter's left)"),
    "azimuth": ReleaseKey(0.0, "rad", -math.pi / 2, math.pi / 2, "throw direction from the +x line "
                          "(positive: towards +y, the shooter's left)"),
    "backspin": ReleaseKey(0.0, "s-1", -500.0, 500.0, "spin about the horizontal axis perpendicular to the "
                           "throw; positive: the top of the ball turns back towards the shooter"),
    "sidespin": ReleaseKey(0.0, "s-1", -500.0, 500.0, "spin about the vertical (positive: counter-clockwise "
                           "seen from above)"),
}
"""The release keys: default, units, allowed range, meaning. ``speed`` must be > 0 and ``distance`` > 0."""


class Contact(NamedTuple):
    """The contact coefficients of the shot's impacts (docs/shots.md derives the defaults).

    e_rim : coefficient of restitution ball-ring [-], in [0, 1]. Default 0.6: the ball's own
        restitution ~0.85 (FIBA ball test: dropped from 1.80 m it rebounds 1.20-1.40 m, e = sqrt(h'/h))
        times sqrt(1 - 0.425) for the ring's absorption of 35-50 % of the energy in the FIBA ring test.
    mu_rim : Coulomb friction ball-ring [-], >= 0 (0.5: rubber on painted steel, an assumption).
    e_board : coefficient of restitution ball-board [-], in [0, 1] (0.8: the ball's own ~0.85 on a
        stiff board, slightly less).
    mu_board : Coulomb friction ball-board [-], >= 0 (0.5, an assumption).
    v_cap : capture speed [m/s], >= 0: a rim impact whose normal rebound speed is below it leaves the
        ball on the ring. Default sqrt(2 g h_cap) with h_cap = 1 mm (a bounce lower than a tenth of
        the tube radius): 0.14 m/s.
    """

    e_rim: float = 0.6
    mu_rim: float = 0.5
    e_board: float = 0.8
    mu_board: float = 0.5
    v_cap: float = 0.14


DEFAULT_CONTACT = Contact()
"""The default contact coefficients (``contact=None``)."""

CONTACT_RANGES = {"e_rim": (0.0, 1.0), "mu_rim": (0.0, 10.0), "e_board": (0.0, 1.0), "mu_board": (0.0, 10.0),
                  "v_cap": (0.0, 10.0)}
"""Allowed closed ranges of the :class:`Contact` fields."""

OUTCOME_MEANINGS = ("swish", "make_rim", "make_board", "make_roll", "airball", "miss_short", "miss_long",
                    "miss_left", "miss_right", "miss_board", "unfinished")
"""Outcome codes (index): makes (no contact; after rim impacts; after a board impact; after rolling on the
ring), misses (no contact; short/long/left/right of the hoop where the centre passes z = -rho; miss_board:
only the board was touched), unfinished (a budget ended the shot, see ``status``)."""

STATUS_MEANINGS = ("ok", "impact_budget", "time_budget", "on_rim", "engine_landing", "rim_board")
"""How a shot's simulation ended: normally; ``max_impacts`` impacts; ``t_max`` seconds in flight; still
on the rim (captured, and the rim engine's outcome is periodic rolling, a steady motion or on the rim
at ``t_max``: see ``rim_outcome``); engine_landing: the state rebuilt at the separation from the rim
would enter the ring at once, and the rim engine's landing rule (fall_in: make_roll; fall_out: a miss)
decided the shot (a guard; the flight normally goes on from the exact separation state, slip included);
rim_board: the ball left the rim overlapping the board's face (the rim phase does not model the board;
outcome unfinished) (docs/shots.md)."""

FIRST_CONTACT_MEANINGS = ("none", "rim", "board")
"""Codes of ``first_contact`` and of the impacts' kinds (rim = 1, board = 2)."""


def params_for(geometry: str, **overrides) -> Params:
    """The Params (paper Table 1) with the ring (R, a) [m] of ``geometry`` and the given other fields."""
    ring = ring_of(geometry)
    for key in ("R", "a"):
        overrides.pop(key, None)
    return Params(**{**overrides, **ring})


def board_x(params: Params, geometry: str = "paper") -> float:
    """x [m] of the board's face for the ring of ``params`` (FIBA: 0.151 m from the ring's inner edge)."""
    ring_of(geometry)
    return board_of(params.R, params.a).x


def check_contact(contact: Contact) -> Contact:
    """``contact`` with float fields; ValueError naming a field outside :data:`CONTACT_RANGES`."""
    if not isinstance(contact, Contact):
        raise ValueError(f"`contact` must be a shots.Contact; got {type(contact).__name__}")
    values = {}
    for name, (low, high) in CONTACT_RANGES.items():
        allowed = f"in [{low:g}, {high:g}]"
        v = real_number(name, getattr(contact, name), allowed=allowed)
        if not low <= v <= high:
            raise ValueError(f"`{name}` must be {allowed}; got {getattr(contact, name)!r}")
        values[name] = v
    return Contact(**values)


def check_releases(releases: dict) -> dict:
    """The release arrays broadcast together (defaults filled in); ValueError naming a key that is
    unknown, missing, not real, or outside its range of :data:`RELEASE`."""
    if not isinstance(releases, dict):
        raise ValueError(f"`releases` must be a dict of the keys {', '.join(RELEASE)}; got {type(releases).__name__}")
    unknown = sorted(set(releases) - set(RELEASE))
    if unknown:
        raise ValueError(f"unknown release key {unknown[0]!r}; the keys are {', '.join(RELEASE)}")
    arrays = {}
    for name, key in RELEASE.items():
        if name not in releases:
            if key.default is None:
                raise ValueError(f"release `{name}` [{key.units}] is required ({key.doc})")
            arrays[name] = np.float64(key.default)
            continue
        value = releases[name]
        try:
            a = np.asarray(value, dtype=float)
        except (TypeError, ValueError):
            raise ValueError(f"release `{name}` must be real numbers [{key.units}]; got {value!r}") from None
        if np.asarray(value).dtype.kind not in "iuf":
            raise ValueError(f"release `{name}` must be real numbers [{key.units}]; got {value!r}")
        strict = name in ("speed", "distance")
        bad = ~np.isfinite(a) | (a < key.low) | (a > key.high) | ((a <= key.low) if strict else False)
        if np.any(bad):
            allowed = f"in ({key.low:g}, {key.high:g}]" if strict else f"in [{key.low:g}, {key.high:g}]"
            raise ValueError(f"release `{name}` must be {allowed} [{key.units}]; got {a[bad].ravel()[0]!r}")
        arrays[name] = a
    shape = np.broadcast_shapes(*(a.shape for a in arrays.values()))
    return {k: np.broadcast_to(a, shape) for k, a in arrays.items()}


def simulate_shots(releases: dict, params: Params, contact: Contact = None, geometry: str | None = None,
                   t_max: float = 5.0, max_impacts: int = 100, lift: bool = False) -> dict:
    """The outcomes of shots: each released as ``releases`` says (:data:`RELEASE`; arrays broadcast
    together) with the ball and ring of ``params`` (``contact=None``: :data:`DEFAULT_CONTACT`; ``geometry``
    names the ring that ``params`` must have, see :func:`params_for`; None: the ring of ``params`` as it
    is) and the board placed at it (FIBA, ``physics.shot_geometry``), followed through its
    flight and impacts until its centre is rho = r + a below the rim plane (no contact possible any more),
    or until ``max_impacts`` impacts or ``t_max`` [s]. In air (``params.rho_air`` > 0) the flights have
    the quadratic drag and, with ``lift=True``, the Magnus lift of ``physics.shot_air`` (off by default;
    it needs rho_air > 0).

    Returns a dict of numpy arrays of the broadcast shape: ``outcome`` (int8, :data:`OUTCOME_MEANINGS`),
    ``status`` (int8, :data:`STATUS_MEANINGS`), ``n_impacts``, ``n_rim_impacts``, ``n_board_impacts``,
    ``n_double_contacts`` (int32), ``t_end`` [s], ``time_on_rim`` [s], ``revolutions_on_rim``,
    ``beta_cap``, ``omega1_cap``, ``omega2_cap``, ``omega3_cap`` [rad, 1/s], ``slip_cap`` [m/s] (NaN:
    never captured), ``first_contact`` (int8, :data:`FIRST_CONTACT_MEANINGS`), ``impact_kinds`` (int64:
    the kinds of the first 20 impacts as base-3 digits, the first impact the lowest digit),
    ``rim_outcome`` (int8: the rim engine's outcome code of the last capture, ``solver.OUTCOME_MEANINGS``;
    -1: never captured).
    """
    from rimroll.solver.engine.shot_loop import run_shots

    checked = check_contact(_contact_or_default(contact))
    return run_shots(check_releases(releases), _checked_params(params, geometry), checked,
                     _budget(t_max, max_impacts), trace=False, lift=_lift(lift, params))


def trace_shot(release: dict, params: Params, contact: Contact = None, geometry: str | None = None,
               t_max: float = 5.0, max_impacts: int = 100, samples_per_flight: int = 200, lift: bool = False) -> dict:
    """One shot's path (``release``: a dict of scalars of :data:`RELEASE`): ``time`` [s], ``x``, ``y``,
    ``z`` [m] of the centre, ``phase`` (0: flight, 1: on the rim) per sample, the impacts' ``impact_time``
    [s], ``impact_x``, ``impact_y``, ``impact_z`` [m], ``impact_kind`` (1: rim, 2: board), and every
    output of :func:`simulate_shots` for this shot as scalars."""
    from rimroll.solver.engine.shot_loop import run_shots

    checked = check_releases(release)
    if checked["speed"].shape != ():
        raise ValueError("`release` of trace_shot must hold scalars (one shot)")
    return run_shots(checked, _checked_params(params, geometry), check_contact(_contact_or_default(contact)),
                     _budget(t_max, max_impacts), trace=int(samples_per_flight), lift=_lift(lift, params))


def speed_to_reach(angle, distance, height, params: Params) -> float:
    """Release speed [m/s] at elevation ``angle`` [rad] whose centre path passes through the hoop's
    centre ``distance`` [m] away and ``height`` [m] above the release. Vacuum (rho_air = 0): the closed
    form v = sqrt(g L^2 / (2 cos^2(angle) (L tan(angle) - h))); NaN where no speed reaches it
    (L tan(angle) <= h). With drag (rho_air > 0): the same by shooting on the flight with drag."""
    from rimroll.solver.physics.release import reach_speed

    return reach_speed(real_number("angle", angle), real_number("distance", distance),
                       real_number("height", height), params)


def _contact_or_default(contact):
    return DEFAULT_CONTACT if contact is None else contact


def _checked_params(params: Params, geometry: str | None) -> Params:
    """``params``; ValueError unless it is a Params whose ring (R, a) is the one of ``geometry`` (if given)."""
    if not isinstance(params, Params):
        raise ValueError(f"`params` must be a rimroll Params; got {type(params).__name__}")
    if geometry is not None:
        ring = ring_of(geometry)
        if (params.R, params.a) != (ring["R"], ring["a"]):
            raise ValueError(f"`geometry` {geometry!r} has the ring R = {ring['R']:g} m, a = {ring['a']:g} m but "
                             f"`params` has R = {params.R:g} m, a = {params.a:g} m; use shots.params_for"
                             f"({geometry!r}, ...) or geometry=None")
    return params


def _lift(lift, params) -> bool:
    """``lift`` after its check: a bool, True only with air (rho_air > 0)."""
    if not isinstance(lift, (bool, np.bool_)):
        raise ValueError(f"`lift` must be True or False (the Magnus lift in flight); got {lift!r}")
    if lift and not params.rho_air > 0.0:
        raise ValueError(f"`lift=True` needs air: params.rho_air must be > 0 kg m-3; got {params.rho_air!r}")
    return bool(lift)


def _budget(t_max, max_impacts) -> tuple[float, int]:
    t = real_number("t_max", t_max, allowed="in (0, 1000] s")
    if not 0.0 < t <= 1000.0:
        raise ValueError(f"`t_max` must be in (0, 1000] s; got {t_max!r}")
    integral = isinstance(max_impacts, (int, np.integer)) and not isinstance(max_impacts, bool)
    if not integral or not 0 <= max_impacts <= 100000:
        raise ValueError(f"`max_impacts` must be an integer in [0, 100000]; got {max_impacts!r}")
    return t, int(max_impacts)
