"""The setting table: every setting of rimroll's studies, declared once (units, doc, allowed values).

Each setting name has one :class:`Setting`: its CF units (``""`` for counts, labels and
switches), a one-line doc, and what it allows: a :class:`~rimroll.solver.physics.params.Range` of
numbers or a set of labels (``choices``). ``sweep`` marks the settings a study may declare
``sweepable`` (a list or range of values becomes an outer axis of the cube, with the units and
``long_name`` given here). The physical parameters (``r R a m j mu g k_r k_d c_r c_d rho_air C_D`` and
``rho_over_R``) are not restated here: their entries are made from the table of
``rimroll.solver.physics.params``, which ``Params`` validates with.

Read by ``study info NAME`` and ``study run NAME --help`` (:mod:`rimroll.study.describe`), by the
checks made before a run (:func:`rimroll.study.checks.check_settings`: ``--set`` values, swept
values and new grid values alike), by ``--set`` sweeps (the axis' units and long_name) and by
``docs/gen_studies.py``. A setting name no study of rimroll uses (a study of another package) is
checked by :data:`WILDCARDS` (``t_max*``, ``n_*``) or, for any other number, by :data:`NUMBER`.
A new setting name gets one entry in :data:`TABLE`; ``tests/study/test_setting_table.py`` fails while a
registered study has a setting without one.
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Callable

from rimroll.solver import shots
from rimroll.solver._arguments import ATOL_MAX, RTOL_RANGE, SLIP_METHODS
from rimroll.solver.physics import params as physical

MAX_AXIS = 100_000  # values of one swept list/range, and of an n_* grid size
MAX_MAGNITUDE = 1e12  # |value| of a numeric setting (coordinates, bounds): far beyond any physical use

Range = physical.Range
NUMBER = Range(-MAX_MAGNITUDE, MAX_MAGNITUDE)
"""Any other number: finite and of magnitude at most :data:`MAX_MAGNITUDE` (an axis spanning
+-1e308 overflows)."""
FINITE = Range(-math.inf, math.inf, low_open=True, high_open=True, text="a finite number")  # magnitude unbounded
NONNEGATIVE = Range(0.0, MAX_MAGNITUDE)
POSITIVE = Range(0.0, MAX_MAGNITUDE, low_open=True)
COUNT = Range(1, MAX_AXIS, integer=True)
COUNT0 = Range(0, MAX_AXIS, integer=True)  # a count that may be 0 (no such eps, no sample)
GRID = Range(2, MAX_AXIS, integer=True)  # points of a grid axis: an axis has at least 2
TOLERANCE = Range(*RTOL_RANGE)  # what solver.simulate accepts as rtol
ABSOLUTE_TOLERANCE = Range(0.0, ATOL_MAX, low_open=True)  # and as atol
FRACTION = Range(0.0, 1.0, low_open=True, high_open=True)
FRICTION = Range(0.0, math.inf)  # a Coulomb coefficient; inf: never slips


_RELEASE = shots.RELEASE


def _release_range(key: str, scale: float = 1.0, low_open: bool = False) -> Range:
    """The solver's range of a release key (``shots.RELEASE``), times ``scale`` (rad -> degree)."""
    return Range(_RELEASE[key].low * scale, _RELEASE[key].high * scale, low_open=low_open)


def _contact_range(key: str) -> Range:
    """The solver's closed range of a contact coefficient (``shots.CONTACT_RANGES``)."""
    return Range(*shots.CONTACT_RANGES[key])


def _methods() -> tuple:
    from rimroll.solver.engine.tableaus import TABLEAUS

    return ("auto",) + tuple(sorted(TABLEAUS))


def _backends() -> tuple:
    from rimroll.solver.engine.backends import BACKENDS

    return tuple(BACKENDS)


@dataclasses.dataclass(frozen=True)
class Setting:
    """One setting: units, doc and what it allows.

    ``range``: the allowed numbers (None: a label or switch, or a number checked only by
    :data:`NUMBER`); ``choices``: the allowed labels, a tuple or a function returning one (looked
    up when a value is checked); ``what``: the plural noun of a choice in a message ("methods").
    ``long_name``: the coordinate's long_name when the setting is swept (default: ``doc``);
    ``physical``: the value goes into ``solver.Params`` (its message then is Params' own).
    """

    name: str
    units: str
    doc: str
    range: Range | None = None
    choices: tuple | Callable[[], tuple] | None = None
    what: str = "values"
    sweep: bool = False
    long_name: str = ""
    physical: bool = False

    @property
    def axis_long_name(self) -> str:
        return self.long_name or self.doc

    def allowed(self, units: bool = True) -> str:
        """What the setting allows, as the messages and the docs state it (``units``: followed by
        the units of a dimensional number)."""
        if self.choices is not None:
            return f"{self.what} {', '.join(self.labels())}"
        rule = self.range or NUMBER
        dimensional = units and self.units not in ("", "1") and not rule.text
        return rule.describe(self.name) + (f" [{self.units}]" if dimensional else "")

    def labels(self) -> tuple:
        return tuple(self.choices() if callable(self.choices) else self.choices)

    def problem(self, value) -> str | None:
        """None if ``value`` is allowed, else the end of a one-line message saying what is."""
        if self.choices is not None:
            labels = self.labels()
            return None if value in labels else f"allowed {self.what} are {', '.join(labels)}"
        if not _number(value):
            return None  # a label or a switch: the study checks it
        rule = self.range or NUMBER
        return None if rule.contains(value) else f"allowed {self.allowed()}"


def _number(value) -> bool:
    return isinstance(value, (int, float)) and not isinstance(value, bool)


def _physical(q: physical.Quantity) -> Setting:
    return Setting(q.name, q.units, q.doc + _DOC_MORE.get(q.name, ""), q.range, sweep=q.name in _SWEPT_PHYSICAL,
                   long_name=q.long_name, physical=True)


_SWEPT_PHYSICAL = ("mu", "j", "rho_over_R", *physical.TERM_KEYS)  # every term's strength
_DOC_MORE = {  # what the study layer adds to a physical parameter's doc
    "mu": "; mu is the only setting that takes inf, and in a study that sweeps it a list may hold inf too: "
          "--set mu=1,inf puts slipping and rolling only on one axis",
}
S = Setting
_ENTRIES = (
    # ---- physical parameters: units, long_name, doc and range from solver.physics.params
    *(_physical(q) for q in physical.QUANTITIES.values()),
    # ---- initial state and steady motions
    # (a swept setting's long_name labels its axis in plots: at most 24 characters, one line in xarray's)
    S("v_throw", "m s-1", "throw speed whose kinetic energy bounds the steady motion (59)",
      NONNEGATIVE, sweep=True, long_name="throw speed"),
    S("omega2", "s-1", "initial orthogonal angular velocity", NUMBER, sweep=True, long_name="initial omega2"),
    S("omega3", "s-1", "initial circular angular velocity", NUMBER, sweep=True, long_name="initial omega3"),
    S("omega30", "s-1", "circular angular velocity of the steady motion", NUMBER),
    S("omega30_max", "s-1", "grid: omega30 in [-omega30_max, omega30_max]", POSITIVE),
    S("omega1_max", "s-1", "grid/sample: omega1 in [-omega1_max, omega1_max]", NUMBER),
    S("omega2_max", "s-1", "sample: |omega2| <= omega2_max", NUMBER),
    S("omega3_max", "s-1", "sample: |omega3| <= omega3_max", NUMBER),
    S("beta_min", "rad", "grid: smallest initial beta", NUMBER),
    S("beta_max", "rad", "grid: largest initial beta", NUMBER),
    S("beta0_min", "rad", "smallest steady beta0", NUMBER),
    S("beta0_max", "rad", "largest steady beta0", NUMBER),
    # the scipy integration of a trajectory takes steps in proportion to |omega1|: 2 s at 10 1/s, 5 s at 100,
    # ~1 min at 1000 over 20 s (one core), hours beyond; the paper's states have |omega1| <= 20 1/s
    S("d_omega1", "s-1", "perturbation of omega1 off the steady motion (|d_omega1| <= 100 1/s: far beyond the "
      "paper's |omega1| <= 20 1/s; the integration's steps grow with it)",
      Range(-100.0, 100.0, text="a number from -100 to 100 (1/s)")),
    # ---- scenes
    S("mu_slip", "1", "friction coefficient of the slipping scenes", FRICTION),
    S("k_dissipation", "s-1", "rate k_d / k_r of the drilling / rolling-resistance scene", NONNEGATIVE),
    S("k_equivalent", "s-1", "strength of every dissipation model: the rate of (83) that removes energy at the same "
      "mean rate on the paper's steady motions; the Coulomb models' arms c_r, c_d must stay below r, which bounds "
      "it further for the ball (about 1.78 1/s for the default one; checked before the run)",
      physical.Range(0.0, 10.0, text="a rate >= 0 and <= 10 [1/s] (500 times the paper's 0.02)"),
      sweep=True, long_name="strength k_eq"),
    # ---- the integration
    S("t_max", "s", "end of a run still on the rim (conservative scenes)", POSITIVE),
    S("t_max_dissipative", "s", "end of a run still on the rim (dissipative scenes)", POSITIVE),
    S("rtol", "1", "relative tolerance of the integrator", TOLERANCE),
    S("atol", "1", "absolute tolerance of the integrator", ABSOLUTE_TOLERANCE),
    S("method", "", "method of solver.simulate (auto: the exact reduced solver in conservative rolling-only scenes, "
      "dp5 elsewhere; dp5: Dormand-Prince 5(4); dop853)", choices=_methods, what="methods"),
    S("backend", "", "where solver.simulate runs (cuda: a GPU, extra rimroll[gpu]; auto: the GPU when usable)",
      choices=_backends, what="backends"),
    S("delta", "m s-1", "launch speed of a slip (Sect. 5.2.2); u_stop = delta, u_floor = delta/100",
      Range(1e-10, 1e-2)),
    S("slip_method", "", "slip phases: rodas4 (Rosenbrock steps while stiff) or explicit (the method's steps)",
      choices=SLIP_METHODS, what="slip methods"),
    S("adaptive", "", "adaptive outcome map: simulate a coarse lattice, refine only non-uniform blocks down to the "
      "grid, fill uniform blocks from their corners (docs/outcome-studies.md#adaptive-maps)"),
    S("adaptive_coarse", "", "adaptive map: grid cells between the points of the coarse lattice (a power of 2)",
      COUNT),
    S("f2_rel", "1", "exact boundaries: a crossing is a grazing of F2 where a rim side ends with f2_min below "
      "f2_rel m g", FRACTION),
    S("rtol_max", "1", "loosest rtol of the sweep", TOLERANCE),
    S("rtol_min", "1", "tightest rtol of the sweep", TOLERANCE),
    S("n_rtol", "", "number of tolerances", COUNT),
    # ---- samples and grids
    S("seed", "", "random seed of the sample", Range(0, MAX_MAGNITUDE, integer=True)),
    S("subset", "", "which region of state space is sampled"),
    S("n_scipy", "", "states scipy runs, rolling only", COUNT),
    S("n_scipy_hybrid", "", "states scipy runs, slipping scenes", COUNT),
    S("n_states", "", "states in the sample", COUNT),
    S("n_samples", "", "states in the sample", COUNT),
    S("n_trajectories", "", "trajectories", COUNT),
    S("n_time", "", "output times per trajectory", COUNT),
    S("n_beta0", "", "grid points of beta0", GRID),
    S("n_omega30", "", "grid points of omega30", GRID),
    S("n_beta", "", "grid points of beta", GRID),
    S("n_omega1", "", "grid points of omega1", GRID),
    S("n_j", "", "grid points of j", GRID),
    S("n_rho_over_R", "", "grid points of rho/R", GRID),
    # ---- a shot (workflows.shot_map; docs/shots.md): the release, the contacts, the ring, the grid
    # (the ranges of the release keys and contact coefficients are the solver's: solver.shots.RELEASE,
    # CONTACT_RANGES; the angles in degrees)
    S("distance", "m", _RELEASE["distance"].doc, _release_range("distance", low_open=True), sweep=True,
      long_name="distance to the hoop"),
    S("height", "m", _RELEASE["height"].doc, _release_range("height"), sweep=True, long_name="rim above the release"),
    S("lateral", "m", _RELEASE["lateral"].doc, _release_range("lateral")),
    S("azimuth", "degree", _RELEASE["azimuth"].doc.replace("+x line", "line through the hoop's axis"),
      _release_range("azimuth", math.degrees(1.0))),
    S("backspin", "s-1", _RELEASE["backspin"].doc + " [rad/s]", _release_range("backspin"), sweep=True,
      long_name="backspin"),
    S("sidespin", "s-1", _RELEASE["sidespin"].doc + " [rad/s]", _release_range("sidespin"), sweep=True,
      long_name="sidespin"),
    S("e_rim", "1", "coefficient of restitution of a ball-ring impact", _contact_range("e_rim"), sweep=True,
      long_name="restitution e (rim)"),
    S("mu_rim", "1", "Coulomb friction coefficient of a ball-ring impact", _contact_range("mu_rim"), sweep=True,
      long_name="friction mu (rim)"),
    S("e_board", "1", "coefficient of restitution of a ball-board impact", _contact_range("e_board"), sweep=True,
      long_name="restitution e (board)"),
    S("mu_board", "1", "Coulomb friction coefficient of a ball-board impact", _contact_range("mu_board"),
      sweep=True, long_name="friction mu (board)"),
    S("v_cap", "m s-1", "capture speed: a rim impact whose normal rebound speed is below it leaves the ball on the "
      "ring", _contact_range("v_cap"), sweep=True, long_name="capture speed v_cap"),
    S("geometry", "", "the ring: paper (Table 1: R = 0.225 m, a = 0.01 m) or regulation (FIBA: R = 0.234 m, "
      "a = 0.009 m); the board is FIBA's for both", choices=tuple(shots.GEOMETRIES), what="geometries",
      sweep=True, long_name="ring geometry"),
    S("t_max_shot", "s", "time budget of one shot from its release (status time budget beyond it)",
      Range(0.0, 1000.0, low_open=True)),
    S("max_impacts", "", "budget of impacts of one shot (status impact budget beyond it)", COUNT),
    S("speed_min", "m s-1", "grid: smallest release speed", _release_range("speed", low_open=True)),
    S("speed_max", "m s-1", "grid: largest release speed", _release_range("speed", low_open=True)),
    S("n_speed", "", "grid points of the release speed", GRID),
    S("angle_min", "degree", "grid: smallest release angle above the horizontal",
      Range(0.0, 90.0, low_open=True, high_open=True)),
    S("angle_max", "degree", "grid: largest release angle above the horizontal",
      Range(0.0, 90.0, low_open=True, high_open=True)),
    S("n_angle", "", "grid points of the release angle", GRID),
    # ---- predictability and make-probability
    S("box", "", "grid points per side of a basin-entropy box", GRID),
    S("n_fine", "", "eps below one grid step: 1/2 ... 1/2^n_fine (simulated)", COUNT0),
    S("n_coarse", "", "eps of whole grid steps: 1 ... 2^n_coarse (read from the grid)", COUNT0),
    S("n_sample", "", "states away from the grid's boundaries simulated for eps < 1", COUNT0),
    S("eps_pairs", "", "eps < 1: sampled (perturbed copies of the edge points and of n_sample others, simulated) "
      "or refined (every grid point, its pairs read from an adaptive map 2^n_fine times finer)",
      choices=("sampled", "refined"), what="ways"),
    S("sigma", "1", "noise level: multiplies sigma_beta ... sigma_omega3", NONNEGATIVE,
      sweep=True, long_name="noise level"),
    S("sigma_beta", "rad", "standard deviation of the arriving beta at sigma = 1", NONNEGATIVE),
    S("sigma_omega1", "s-1", "standard deviation of the arriving omega1 at sigma = 1", NONNEGATIVE),
    S("sigma_omega2", "s-1", "standard deviation of the arriving omega2 at sigma = 1", NONNEGATIVE),
    S("sigma_omega3", "s-1", "standard deviation of the arriving omega3 at sigma = 1", NONNEGATIVE),
    S("confidence", "1", "confidence level of the Wilson intervals", FRACTION),
    # ---- shot-probability, rim-states (workflows.shot_probability, workflows.rim_states)
    S("sd_speed", "m s-1", "standard deviation of the release speed (Slegers et al. 2021: 0.05-0.13 m/s)",
      NONNEGATIVE, sweep=True, long_name="release speed SD"),
    S("sd_angle", "degree", "standard deviation of the release angle (Slegers et al. 2021: about 1.3 degree)",
      NONNEGATIVE, sweep=True, long_name="release angle SD"),
    S("sd_backspin", "s-1", "standard deviation of the backspin [rad/s]", NONNEGATIVE),
    S("sd_azimuth", "degree", "standard deviation of the sideways aim (azimuth)", NONNEGATIVE),
    S("draws", "", "noisy releases per nominal release (a setting of the estimate, not a grid size: compared by "
      "study verify)", COUNT),
    S("speed", "m s-1", "nominal release speed", _release_range("speed", low_open=True)),
    S("angle", "degree", "nominal release angle above the horizontal", Range(0.0, 90.0, low_open=True,
                                                                               high_open=True)),
    S("dv_min", "m s-1", "grid: smallest release speed above the speed through the hoop's centre", NUMBER),
    S("dv_max", "m s-1", "grid: largest release speed above the speed through the hoop's centre", NUMBER),
    S("n_dv", "", "grid points of the release speed above the speed through the hoop's centre", GRID),
    S("azimuth_max", "degree", "grid: largest sideways aim (the grid is symmetric about 0)", Range(0.0, 90.0,
                                                                                                  low_open=True)),
    S("n_azimuth", "", "grid points of the sideways aim", GRID),
    S("makes", "", "which makes count: all, or swish_only (a shot that touches the rim or the board is a miss)",
      choices=("all", "swish_only"), what="choices"),
)
del S


def _table(entries) -> dict[str, Setting]:
    """Name -> Setting; a name declared twice is an error (a setting is declared once)."""
    table: dict[str, Setting] = {}
    for entry in entries:
        if entry.name in table:
            raise ValueError(f"setting {entry.name!r} is declared twice in the setting table")
        if entry.range is not None and entry.choices is not None:
            raise ValueError(f"setting {entry.name!r}: give a range of numbers or choices of labels, not both")
        table[entry.name] = entry
    return table


TABLE: dict[str, Setting] = _table(_ENTRIES)
"""Every setting of rimroll's studies, by name."""

MAY_BE_EQUAL = ("beta0",)
"""Stems of ``*_min``/``*_max`` pairs that may be equal: a sample uniform in [low, high] (``beta0``: the
invariants' initial heights) may be one value; every other pair spans an axis or a range, low < high."""


def ordered_pairs(names) -> tuple:
    """``(low, high, strict)`` for every pair ``X_min``, ``X_max`` among ``names``: the settings whose values
    must be ordered, ``low < high`` (``low <= high`` for the stems of :data:`MAY_BE_EQUAL`)."""
    names = set(names)
    return tuple((f"{stem}_min", f"{stem}_max", stem not in MAY_BE_EQUAL)
                 for stem in sorted(n[:-4] for n in names if n.endswith("_min")) if f"{stem}_max" in names)


ORDERED = ordered_pairs(TABLE)
"""Every ``*_min``/``*_max`` pair of :data:`TABLE` (``beta_min < beta_max``, ``beta0_min <= beta0_max``,
``rtol_min < rtol_max``, ...), checked with the ranges before any work; a study's own settings of that form
that the table does not declare are ordered by the same rule (``checks.check_order``)."""

WILDCARDS = (("t_max", Setting("t_max*", "s", "", POSITIVE)), ("n_", Setting("n_*", "", "", COUNT)))
"""Rules by name prefix for setting names that :data:`TABLE` does not declare (another package's studies)."""

SWEEP_KEYS = tuple(name for name, s in TABLE.items() if s.sweep)
"""Settings a study may declare ``sweepable``: a list or range of values becomes an outer axis."""


def lookup(name: str) -> Setting:
    """The table's entry of ``name``; for an undeclared name the wildcard it matches, else a
    :data:`NUMBER` rule without units or doc."""
    if name in TABLE:
        return TABLE[name]
    for prefix, rule in WILDCARDS:
        if name.startswith(prefix):
            return dataclasses.replace(rule, name=name)
    return Setting(name, "", "")
