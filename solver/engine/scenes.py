"""The scene table: which phases and which terms of the equations a run compiles, declared once.

A scene is the physics one run needs, read off :class:`Params` (docs/outcome-engine.md, Scenes):

* the **phases**: a ball with finite ``mu`` can slip (``slips``: rolling until the friction cone
  (39) is left, slipping (42), rolling again, Sect. 5.2.2); with ``mu = inf`` it only rolls;
* the **terms** on top of the conservative rolling (and slipping) equations: today the contact
  moment of (83) in its two components, rolling resistance (``k_r``) and drilling resistance
  (``k_d``) (:data:`TERMS`). A scene without terms is conservative: periodic rolling is detected
  (Prop. 4); with any term the run ends at a fall or at t_max.

Everything that depends on the scene reads it from here: ``simulate`` (which compiled kernel
runs), the scene kernels and the CUDA launcher (their literal flags :attr:`Scene.flags`), the scipy
reference, and the outcome studies and their plots (the four named scenes of Figs. 11-13,
:data:`NAMED`). Adding a term means one entry of :data:`TERMS`, its parameter in ``Params`` and
its contribution to the equations in ``solver.physics``.
"""

from __future__ import annotations

import dataclasses

from rimroll.solver.physics.params import Params


@dataclasses.dataclass(frozen=True)
class Term:
    """A term added to the conservative equations of motion, switched on by its parameter."""

    name: str
    parameter: str  # the Params field that sets its strength; 0 switches the term off
    text: str  # reader-facing, with the paper's equation


TERMS = (
    Term("drilling", "k_d", "drilling resistance (83)"),
    Term("rolling_resistance", "k_r", "rolling resistance (83)"),
)
"""The terms a scene may hold, in the order their names are listed in a scene."""
_TERM = {t.name: t for t in TERMS}


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
        unknown = [t for t in self.terms if t not in _TERM]
        if unknown:
            raise ValueError(f"scene {self.name!r}: unknown terms {unknown}; known: {', '.join(_TERM)}")

    @property
    def conservative(self) -> bool:
        """No term removes energy: periodic rolling is detected (Prop. 4)."""
        return not self.terms

    @property
    def flags(self) -> tuple[bool, bool]:
        """(hybrid, conservative): the literal flags of the compiled scene kernel that runs this scene."""
        return self.slips, self.conservative

    @property
    def kernel(self) -> str:
        """Name of the compiled kernel of this scene (one per value of :attr:`flags`)."""
        return kernel_name(*self.flags)

    def parameters(self, mu: float, strength: float) -> dict[str, float]:
        """mu and every term's parameter for this scene: ``mu`` if it slips (else inf), ``strength``
        for the parameter of each of its terms, 0 for the others."""
        out = {"mu": float(mu) if self.slips else float("inf")}
        for term in TERMS:
            out[term.parameter] = float(strength) if term.name in self.terms else 0.0
        return out


def kernel_name(hybrid: bool, conservative: bool) -> str:
    """``scene_<rolling|hybrid>_<conservative|dissipative>``: the scene kernel of these flags."""
    return f"scene_{'hybrid' if hybrid else 'rolling'}_{'conservative' if conservative else 'dissipative'}"


KERNEL_FLAGS = ((False, True), (False, False), (True, True), (True, False))
"""The (hybrid, conservative) flags of the four compiled scene kernels."""

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
    terms = tuple(t.name for t in TERMS if t.name in terms)  # table order
    for scene in NAMED:
        if scene.slips == slips and scene.terms == terms:
            return scene
    base = "slipping" if slips else "rolling_only"
    text = ("slipping" if slips else "rolling only") + "".join(f" + {_TERM[t].text}" for t in terms)
    return Scene("+".join((base, *terms)), text, slips, terms)


def named(name: str) -> Scene:
    """The scene called ``name``: one of :data:`NAMED`, or a composition ``rolling_only+drilling``;
    ValueError naming what is allowed otherwise."""
    if name in BY_NAME:
        return BY_NAME[name]
    base, *terms = name.split("+")
    if base not in ("rolling_only", "slipping") or any(t not in _TERM for t in terms):
        raise ValueError(f"unknown scene {name!r}; named scenes: {', '.join(BY_NAME)}, or rolling_only / slipping "
                         f"followed by +TERM for terms among {', '.join(_TERM)}")
    return composed(base == "slipping", terms)


def scene_of(params: Params) -> Scene:
    """The scene of a run with these parameters (:func:`composed` of its phases and terms)."""
    return composed(not params.rolling_only, tuple(t.name for t in TERMS if getattr(params, t.parameter) > 0))
