"""Coefficient tables of the embedded Runge-Kutta pairs used by ``solver.engine.stepper``.

A method is data: a :class:`Tableau` holds the Butcher coefficients of the step, the error
estimator and the dense-output polynomial, all as plain float64 arrays that the one generic
compiled stepper reads. Adding a method means adding a table here, not a loop.

Conventions (shared by every table; ``s = n_stages``):

* ``A`` is ``(n_dense, n_dense)``: rows ``0 .. s-1`` are the stages of the step; row ``s`` is the
  first-same-as-last stage ``f(t + h, y_new)`` (so ``A[s, :s] == B`` and ``C[s] == 1``); rows
  ``s+1 ..`` are extra stages needed only by the dense output (DOP853 has three).
* ``E`` is ``(2, s + 1)``: error weights on the ``s + 1`` stages (the last is the FSAL stage).
  ``err_mode`` 0: the estimate is ``h K^T E[0]`` with an RMS norm (Dormand-Prince 5(4)).
  ``err_mode`` 1: Hairer's DOP853 combination of the 5th- (``E[0]``) and 3rd-order (``E[1]``)
  estimates, ``|h| n5^2 / sqrt(n (n5^2 + 0.01 n3^2))``.
* ``P`` is ``(n_dense, n_poly)``: the dense output on the step ``[t, t + h]`` is
  ``y(t + theta h) = y + h * sum_k K_k * sum_q P[k, q] theta^(q + 1)``.
* ``error_order`` is the order of the error estimator: the step-size exponent is
  ``-1 / (error_order + 1)`` and the initial-step rule uses it too.

References: Dormand & Prince, J. Comput. Appl. Math. 6 (1980) 19-26; Shampine, Math. Comp. 46
(1986) 135-150 (the 4th-order dense output); Hairer, Norsett & Wanner, Solving ODEs I, 2nd ed.,
Sect. II.10 (DOP853 and its 7th-order dense output). The DOP853 numbers are those of Hairer's
Fortran code as shipped in ``scipy.integrate`` (``dop853_coefficients``); its dense output is
re-expressed here in the polynomial form above.
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np


class Method(NamedTuple):
    """What the compiled stepper reads of a :class:`Tableau`: one record, numbers and arrays only."""

    A: np.ndarray  # (n_dense, n_dense)
    E: np.ndarray  # (2, n_stages + 1)
    P: np.ndarray  # (n_dense, n_poly)
    n_stages: int
    err_mode: int
    error_order: int


class Tableau(NamedTuple):
    """An embedded explicit Runge-Kutta pair with dense output (see the module docstring)."""

    name: str
    order: int  # order of the propagated solution
    error_order: int  # order of the error estimator
    n_stages: int
    A: np.ndarray  # (n_dense, n_dense)
    B: np.ndarray  # (n_stages,)
    C: np.ndarray  # (n_dense,)
    E: np.ndarray  # (2, n_stages + 1)
    err_mode: int
    P: np.ndarray  # (n_dense, n_poly)

    @property
    def n_dense(self) -> int:
        return self.A.shape[0]

    @property
    def n_poly(self) -> int:
        return self.P.shape[1]

    @property
    def method(self) -> Method:
        """The record the compiled stepper takes."""
        return Method(self.A, self.E, self.P, self.n_stages, self.err_mode, self.error_order)


# --------------------------------------------------------------------------------------------
# Dormand-Prince 5(4), FSAL, with Shampine's free 4th-order dense output
# --------------------------------------------------------------------------------------------

_DP5_A = np.array(
    [
        [0, 0, 0, 0, 0, 0, 0],
        [1 / 5, 0, 0, 0, 0, 0, 0],
        [3 / 40, 9 / 40, 0, 0, 0, 0, 0],
        [44 / 45, -56 / 15, 32 / 9, 0, 0, 0, 0],
        [19372 / 6561, -25360 / 2187, 64448 / 6561, -212 / 729, 0, 0, 0],
        [9017 / 3168, -355 / 33, 46732 / 5247, 49 / 176, -5103 / 18656, 0, 0],
        [35 / 384, 0, 500 / 1113, 125 / 192, -2187 / 6784, 11 / 84, 0],
    ]
)
_DP5_C = np.array([0, 1 / 5, 3 / 10, 4 / 5, 8 / 9, 1, 1])
_DP5_E = np.array(
    [
        [-71 / 57600, 0, 71 / 16695, -71 / 1920, 17253 / 339200, -22 / 525, 1 / 40],
        [0, 0, 0, 0, 0, 0, 0],
    ]
)
_DP5_P = np.array(
    [
        [1, -8048581381 / 2820520608, 8663915743 / 2820520608, -12715105075 / 11282082432],
        [0, 0, 0, 0],
        [0, 131558114200 / 32700410799, -68118460800 / 10900136933, 87487479700 / 32700410799],
        [0, -1754552775 / 470086768, 14199869525 / 1410260304, -10690763975 / 1880347072],
        [0, 127303824393 / 49829197408, -318862633887 / 49829197408, 701980252875 / 199316789632],
        [0, -282668133 / 205662961, 2019193451 / 616988883, -1453857185 / 822651844],
        [0, 40617522 / 29380423, -110615467 / 29380423, 69997945 / 29380423],
    ]
)

DP5 = Tableau("dp5", 5, 4, 6, _DP5_A, _DP5_A[6, :6].copy(), _DP5_C, _DP5_E, 0, _DP5_P)

# --------------------------------------------------------------------------------------------
# DOP853: Dormand-Prince 8(5,3) with a 7th-order dense output (3 extra stages)
# --------------------------------------------------------------------------------------------

_DOP853_A = (
    {},
    {0: 0.05260015195876773},
    {0: 0.0197250569845379, 1: 0.0591751709536137},
    {0: 0.02958758547680685, 2: 0.08876275643042054},
    {0: 0.2413651341592667, 2: -0.8845494793282861, 3: 0.924834003261792},
    {0: 0.037037037037037035, 3: 0.17082860872947386, 4: 0.12546768756682242},
    {0: 0.037109375, 3: 0.17025221101954405, 4: 0.06021653898045596, 5: -0.017578125},
    {0: 0.03709200011850479, 3: 0.17038392571223998, 4: 0.10726203044637328, 5: -0.015319437748624402, 6: 0.008273789163814023},
    {0: 0.6241109587160757, 3: -3.3608926294469414, 4: -0.868219346841726, 5: 27.59209969944671, 6: 20.154067550477894, 7: -43.48988418106996},
    {0: 0.47766253643826434, 3: -2.4881146199716677, 4: -0.590290826836843, 5: 21.230051448181193, 6: 15.279233632882423, 7: -33.28821096898486, 8: -0.020331201708508627},
    {0: -0.9371424300859873, 3: 5.186372428844064, 4: 1.0914373489967295, 5: -8.149787010746927, 6: -18.52006565999696, 7: 22.739487099350505, 8: 2.4936055526796523, 9: -3.0467644718982196},
    {0: 2.273310147516538, 3: -10.53449546673725, 4: -2.0008720582248625, 5: -17.9589318631188, 6: 27.94888452941996, 7: -2.8589982771350235, 8: -8.87285693353063, 9: 12.360567175794303, 10: 0.6433927460157636},
    {0: 0.054293734116568765, 5: 4.450312892752409, 6: 1.8915178993145003, 7: -5.801203960010585, 8: 0.3111643669578199, 9: -0.1521609496625161, 10: 0.20136540080403034, 11: 0.04471061572777259},
    {0: 0.056167502283047954, 6: 0.25350021021662483, 7: -0.2462390374708025, 8: -0.12419142326381637, 9: 0.15329179827876568, 10: 0.00820105229563469, 11: 0.007567897660545699, 12: -0.008298},
    {0: 0.03183464816350214, 5: 0.028300909672366776, 6: 0.053541988307438566, 7: -0.05492374857139099, 10: -0.00010834732869724932, 11: 0.0003825710908356584, 12: -0.00034046500868740456, 13: 0.1413124436746325},
    {0: -0.42889630158379194, 5: -4.697621415361164, 6: 7.683421196062599, 7: 4.06898981839711, 8: 0.3567271874552811, 12: -0.0013990241651590145, 13: 2.9475147891527724, 14: -9.15095847217987},
)
_DOP853_C = [0.0, 0.05260015195876773, 0.0789002279381516, 0.1183503419072274, 0.2816496580927726, 0.3333333333333333, 0.25, 0.3076923076923077, 0.6512820512820513, 0.6, 0.8571428571428571, 1.0, 1.0, 0.1, 0.2, 0.7777777777777778]
_DOP853_E = (
    {0: 0.01312004499419488, 5: -1.2251564463762044, 6: -0.4957589496572502, 7: 1.6643771824549864, 8: -0.35032884874997366, 9: 0.3341791187130175, 10: 0.08192320648511571, 11: -0.022355307863886294},
    {0: -0.18980075407240762, 5: 4.450312892752409, 6: 1.8915178993145003, 7: -5.801203960010585, 8: -0.4226823213237919, 9: -0.1521609496625161, 10: 0.20136540080403034, 11: 0.02265179219836082},
)
_DOP853_D = (
    {0: -8.428938276109013, 5: 0.5667149535193777, 6: -3.0689499459498917, 7: 2.38466765651207, 8: 2.117034582445028, 9: -0.871391583777973, 10: 2.2404374302607883, 11: 0.6315787787694688, 12: -0.08899033645133331, 13: 18.148505520854727, 14: -9.194632392478356, 15: -4.436036387594894},
    {0: 10.427508642579134, 5: 242.28349177525817, 6: 165.20045171727028, 7: -374.5467547226902, 8: -22.113666853125306, 9: 7.733432668472264, 10: -30.674084731089398, 11: -9.332130526430229, 12: 15.697238121770845, 13: -31.139403219565178, 14: -9.35292435884448, 15: 35.81684148639408},
    {0: 19.985053242002433, 5: -387.0373087493518, 6: -189.17813819516758, 7: 527.8081592054236, 8: -11.57390253995963, 9: 6.8812326946963, 10: -1.0006050966910838, 11: 0.7777137798053443, 12: -2.778205752353508, 13: -60.19669523126412, 14: 84.32040550667716, 15: 11.99229113618279},
    {0: -25.69393346270375, 5: -154.18974869023643, 6: -231.5293791760455, 7: 357.6391179106141, 8: 93.40532418362432, 9: -37.45832313645163, 10: 104.0996495089623, 11: 29.8402934266605, 12: -43.53345659001114, 13: 96.32455395918828, 14: -39.17726167561544, 15: -149.72683625798564},
)


def _dense(rows, shape):
    out = np.zeros(shape)
    for i, row in enumerate(rows):
        for j, v in row.items():
            out[i, j] = v
    return out


def _dop853_poly(A, D, n_stages):
    """Polynomial dense-output weights P (n_dense, 7) of DOP853.

    Hairer's interpolant is y_old + sum_i F_i w_i(x), nested as
    ``(((F6 x + F5)(1 - x) + F4) x + F3)(1 - x) ... ) x`` with F0 = dy, F1 = h f0 - dy,
    F2 = 2 dy - h (f0 + f_new), F3..F6 = h D K, and dy = h B K: every F_i is linear in h K, so
    the interpolant is y_old + h sum_k K_k P_k(x). Expanded here once, exactly as scipy's loop.
    """
    n_dense = A.shape[0]
    B = A[n_stages, :n_stages]
    dy = np.zeros(n_dense)
    dy[:n_stages] = B
    f0 = np.zeros(n_dense)
    f0[0] = 1.0
    f_new = np.zeros(n_dense)
    f_new[n_stages] = 1.0
    F = [dy, f0 - dy, 2 * dy - (f0 + f_new)] + [D[i] for i in range(D.shape[0])]
    x = (0.0, 1.0)  # coefficients of x in powers of x
    one_minus_x = (1.0, -1.0)
    # w: per stage, coefficients in powers of x, built by the same nesting as the Fortran code
    acc = np.zeros((n_dense, 1))
    for i, Fi in enumerate(reversed(F)):
        acc = acc + np.pad(Fi[:, None], ((0, 0), (0, acc.shape[1] - 1)))
        factor = x if i % 2 == 0 else one_minus_x
        grown = np.zeros((n_dense, acc.shape[1] + 1))
        grown[:, :-1] += factor[0] * acc
        grown[:, 1:] += factor[1] * acc
        acc = grown
    assert np.allclose(acc[:, 0], 0.0)
    return acc[:, 1:]


_A853 = _dense(_DOP853_A, (16, 16))
_N853 = 12
DOP853 = Tableau(
    "dop853",
    8,
    7,
    _N853,
    _A853,
    _A853[_N853, :_N853].copy(),
    np.array(_DOP853_C),
    _dense(_DOP853_E, (2, _N853 + 1)),
    1,
    _dop853_poly(_A853, _dense(_DOP853_D, (4, 16)), _N853),
)

TABLEAUS = {"dp5": DP5, "dop853": DOP853}
"""The methods ``solver.simulate`` accepts, by name."""
