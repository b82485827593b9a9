"""The scene table: which phases and which terms of the equations a run compiles, declared once.

A scene is the physics one run needs (docs/outcome-engine.md, Scenes):

* the **phases**: a ball with finite ``mu`` can slip (``slips``: rolling until the friction cone
  (39) is left, slipping (42), rolling again, Sect. 5.2.2); with ``mu = inf`` it only rolls;
* the **terms** on top of the conservative rolling (and slipping) equations (:data:`TERMS`). The
  contact moment of (83), in its two components (rolling resistance ``k_r``, drilling resistance
  ``k_d``), is built into the equations and switched on by its parameter. Any other term is a
  *load*: a function of the state giving a moment about the ball's centre and a force at it
  (``solver.physics.loads``), which the engine adds to the equations of both phases; a scene with
  load terms gets a kernel of its own that compiles exactly those terms (``solver.engine.scene_code``),
  and a scene without them compiles none. A scene without dissipative terms is conservative:
  periodic rolling is detected (Prop. 4); otherwise the run ends at a fall or at t_max.

Everything that depends on the scene reads it from here: ``simulate`` (which compiled kernel runs,
``terms=``), the scene kernels and the CUDA launcher (their literal flags :attr:`Scene.flags`), the
scipy reference, and the outcome studies and their plots (the four named scenes of Figs. 11-13,
:data:`NAMED`). Adding a term means one physics function and one :func:`register_term` (or an
entry of :data:`TERMS`).
"""

from __future__ import annotations

import dataclasses
from collections.abc import Callable

from rimroll.solver.physics import air, resistance
from rimroll.solver.physics.params import Params


@dataclasses.dataclass(frozen=True)
class Term:
    """A term added to the conservative equations of motion.

    ``parameter``: the ``Params`` field whose nonzero value switches the term on in ``scene_of``
    (None: the term is only run when named, ``simulate(..., terms=...)``). ``load``: a compiled
    physics function ``load(beta, omega1, omega2, omega3, u1, u3, p) -> (M1, M2, M3, F1, F2, F3)``
    [N m, N] in the contact basis (``solver.physics.loads``), defined at the top level of an
    importable module; None for a term built into the equations ((83)). ``dissipative``: the term
    removes energy (periodic rolling is then not detected).
    """

    name: str
    text: str  # reader-facing, with the paper's equation where there is one
    parameter: str | None = None
    load: Callable | None = None
    dissipative: bool = True

    def __post_init__(self):
        if self.parameter is None and self.load is None:
            raise ValueError(f"term {self.name!r}: give the Params field that switches it on, its load function, "
                             "or both")


TERMS: dict[str, Term] = {}
"""The terms a scene may hold, by name, in the order they are listed in a scene."""


def register_term(term: Term) -> Term:
    """Add a term to :data:`TERMS` (a second term of the same name is an error unless it is the same)."""
    if not isinstance(term, Term):
        raise ValueError(f"register_term takes a Term; got {type(term).__name__}")
    if term.name in TERMS and TERMS[term.name] != term:
        raise ValueError(f"a term named {term.name!r} is already in the scene table")
    TERMS[term.name] = term
    return term


register_term(Term("drilling", "drilling resistance (83)", parameter="k_d"))
register_term(Term("rolling_resistance", "rolling resistance (83)", parameter="k_r"))
register_term(Term("coulomb_rolling", "Coulomb rolling resistance", parameter="c_r", load=resistance.coulomb_rolling))
register_term(Term("coulomb_drilling", "Coulomb drilling resistance", parameter="c_d",
                   load=resistance.coulomb_drilling))
register_term(Term("air_drag", "air drag", parameter="rho_air", load=air.air_drag))


@dataclasses.dataclass(frozen=True)
class Scene:
    """The phases and terms of one run.

    ``name`` is a label (a ``scene`` coordinate of the outcome files for the named scenes),
    ``text`` its reader-facing name, ``slips`` whether the ball can slip (finite mu), ``terms``
    the names of the terms of :data:`TERMS` it holds (none: conservative).
    """

    name: str
    text: str
    slips: bool
    terms: tuple = ()

    def __post_init__(self):
        unknown = [t for t in self.terms if t not in TERMS]
        if unknown:
            raise ValueError(f"scene {self.name!r}: unknown terms {unknown}; known: {', '.join(TERMS)}")

    @property
    def conservative(self) -> bool:
        """No term removes energy: periodic rolling is detected (Prop. 4)."""
        return not any(TERMS[t].dissipative for t in self.terms)

    def dissipates(self, params: Params) -> bool:
        """Whether a term of the scene removes energy in a run with these parameters: a dissipative
        term that is not switched by a parameter, or one whose parameter is nonzero. Periodic rolling
        is detected otherwise (a term named at zero strength leaves the run conservative)."""
        return any(TERMS[t].dissipative and (TERMS[t].parameter is None or getattr(params, TERMS[t].parameter) > 0)
                   for t in self.terms)

    @property
    def loads(self) -> tuple[Term, ...]:
        """The terms that enter the equations as a load (each with its ``load`` function)."""
        return tuple(TERMS[t] for t in self.terms if TERMS[t].load is not None)

    @property
    def flags(self) -> tuple[bool, bool]:
        """(hybrid, conservative): the literal flags of the compiled scene kernel that runs this scene."""
        return self.slips, self.conservative

    @property
    def kernel(self) -> str:
        """Name of the compiled kernel of this scene's phases: ``scene_rolling`` or ``scene_hybrid`` (a
        scene with load terms runs a kernel generated from it, ``solver.engine.scene_code``); whether
        periodic rolling is detected is a run-time setting of both (``kernels.Limits.periodic``)."""
        return kernel_name(self.slips)

    def parameters(self, mu: float, strength: float) -> dict[str, float]:
        """mu and every parametrised term's parameter for this scene: ``mu`` if it slips (else inf),
        ``strength`` for the parameter of each of its terms, 0 for the others."""
        out = {"mu": float(mu) if self.slips else float("inf")}
        for term in TERMS.values():
            if term.parameter is not None:
                out[term.parameter] = float(strength) if term.name in self.terms else 0.0
        return out


def kernel_name(hybrid: bool) -> str:
    """``scene_rolling`` or ``scene_hybrid``: the scene kernel of scenes that only roll or also slip."""
    return f"scene_{'hybrid' if hybrid else 'rolling'}"

NAMED = (
    Scene("rolling_only", "rolling only", slips=False),
    Scene("slipping", "slipping", slips=True),
    Scene("drilling", "slipping + drilling resistance", slips=True, terms=("drilling",)),
    Scene("rolling_resistance", "slipping + rolling resistance", slips=True, terms=("rolling_resistance",)),
)
"""The four scenes of the outcome sections of Figs. 11-13, in file order (paper Sect. 5.3)."""
BY_NAME = {s.name: s for s in NAMED}


def composed(slips: bool, terms=()) -> Scene:
    """The scene of these phases and terms: the named one where one matches, else one named
    ``<rolling_only|slipping>+<term>+...`` (e.g. ``rolling_only+rolling_resistance``)."""
    unknown = [t for t in terms if t not in TERMS]
    if unknown:
        raise ValueError(f"unknown terms {unknown}; known: {', '.join(TERMS)}")
    terms = tuple(t for t in TERMS if t in terms)  # table order
    for scene in NAMED:
        if scene.slips == slips and scene.terms == terms:
            return scene
    base = "slipping" if slips else "rolling_only"
    text = ("slipping" if slips else "rolling only") + "".join(f" + {TERMS[t].text}" for t in terms)
    return Scene("+".join((base, *terms)), text, slips, terms)


def named(name: str) -> Scene:
    """The scene called ``name``: one of :data:`NAMED`, or a composition ``rolling_only+drilling``;
    ValueError naming what is allowed otherwise."""
    if name in BY_NAME:
        return BY_NAME[name]
    base, *terms = name.split("+")
    if base not in ("rolling_only", "slipping") or any(t not in TERMS for t in terms):
        raise ValueError(f"unknown scene {name!r}; named scenes: {', '.join(BY_NAME)}, or rolling_only / slipping "
                         f"followed by +TERM for terms among {', '.join(TERMS)}")
    return composed(base == "slipping", terms)


def scene_of(params: Params, terms=()) -> Scene:
    """The scene of a run with these parameters (its phases; every term whose parameter is nonzero)
    and the load terms named in ``terms`` (a sequence of names, or one name)."""
    terms = (terms,) if isinstance(terms, str) else tuple(terms or ())
    on = [t.name for t in TERMS.values() if t.parameter is not None and getattr(params, t.parameter) > 0]
    bad = [t for t in terms if t in TERMS and TERMS[t].load is None]
    if bad:
        switches = ", ".join(TERMS[t].parameter for t in bad)
        raise ValueError(f"terms {bad} are switched on by their parameter ({switches}), not named in terms=")
    return composed(not params.rolling_only, (*on, *terms))
