"""The event-driven loop of shots: flights, contact times, impacts, the end of each shot.

Each shot: from the release, the flight (``physics.shot_flight``) is searched for the first contact
with the ring or the board (``physics.contact_times``) before the centre falls below z = -rho
(rho = r + a; below it no point of the ball can reach the ring, whose tube spans |z| <= a, nor, in
practice, the board's face, whose lower edge is 0.15 m below the ring's top); at a contact the impact
law (``physics.impact``) changes the velocity and spin, and the search goes on. Rim and board at
once: the impacts are applied one after the other in time order (each only if the ball still
approaches that surface); two impacts of different kinds within :data:`DOUBLE_WINDOW` count as one
double contact. A capture onto the rim (``shot_capture``) suspends the shot: all shots are run in
rounds, each round's captured shots going to the rim engine in ONE ``simulate`` call
(``shot_capture.roll_batch``) before their flights go on. The shot ends at z = -rho (make if the
centre is then less than R from the hoop's axis), or at ``max_impacts`` impacts or ``t_max`` seconds
(status, outcome ``unfinished``). The rim engine does not see the board: a stay on the rim whose
separation state overlaps the board's face ends the shot with status ``rim_board`` (outcome
``unfinished``); one whose path passes behind the face and comes back is not detected.
"""

from __future__ import annotations

import math

import numpy as np

from rimroll.solver.engine.outcomes import FALL_IN
from rimroll.solver.engine.shot_capture import capture_impact, roll_batch
from rimroll.solver.physics.contact_times import first_plane_contact, first_ring_contact
from rimroll.solver.physics.impact import impact
from rimroll.solver.physics.release import release_state
from rimroll.solver.physics.shot_flight import Flight
from rimroll.solver.physics.shot_geometry import board_of, ring_normal

DOUBLE_WINDOW = 1e-3
"""[s] two impacts of different kinds (rim, board) closer in time than this are one double contact."""
RIM, BOARD = 1, 2
OUTCOMES = ("swish", "make_rim", "make_board", "make_roll", "airball", "miss_short", "miss_long",
            "miss_left", "miss_right", "miss_board", "unfinished")
STATUSES = ("ok", "impact_budget", "time_budget", "on_rim", "engine_landing", "rim_board")
KIND_DIGITS = 20
"""Impacts recorded in ``impact_kinds`` (base-3 digits of an int64)."""
FLOAT_OUTPUTS = ("t_end", "time_on_rim", "revolutions_on_rim", "beta_cap", "omega1_cap", "omega2_cap",
                 "omega3_cap", "slip_cap")
CAPTURE_KEYS = ("beta_cap", "omega1_cap", "omega2_cap", "omega3_cap", "slip_cap")
INT_OUTPUTS = {"outcome": np.int8, "status": np.int8, "n_impacts": np.int32, "n_rim_impacts": np.int32,
               "n_board_impacts": np.int32, "n_double_contacts": np.int32, "first_contact": np.int8,
               "impact_kinds": np.int64, "rim_outcome": np.int8}


def run_shots(releases: dict, params, contact, budget: tuple[float, int], trace=False, lift: bool = False) -> dict:
    """The outputs of ``shots.simulate_shots`` for the broadcast ``releases`` (or, with ``trace`` a
    number of samples per flight, the path of the one shot as ``shots.trace_shot`` returns it); ``lift``:
    flights with the Magnus lift (``physics.shot_air``)."""
    shape = releases["speed"].shape
    flat = {k: np.ravel(v) for k, v in releases.items()}
    n = flat["speed"].size
    out = {k: np.full(n, np.nan) for k in FLOAT_OUTPUTS}
    out.update({k: np.zeros(n, dtype) for k, dtype in INT_OUTPUTS.items()})
    out["rim_outcome"][:] = -1
    path = _Path() if trace else None
    pending = {}  # shots waiting for the rim engine: index -> (generator, its request)
    for i in range(n):
        shot = one_shot({k: float(v[i]) for k, v in flat.items()}, params, contact, budget, path, trace, lift)
        _advance(out, pending, i, shot, None)
    while pending:  # a round: every captured shot's rim phase in one engine call, then their flights on
        runs = roll_batch([request for _, request in pending.values()], params)
        waiting, pending = pending, {}
        for (i, (shot, _)), run in zip(waiting.items(), runs):
            _advance(out, pending, i, shot, run)
    if trace:
        return {**{k: v.reshape(shape)[()] for k, v in out.items()}, **path.arrays()}
    return {k: v.reshape(shape) for k, v in out.items()}


def _advance(out: dict, pending: dict, i: int, shot, reply) -> None:
    """Run shot ``i`` (a generator from :func:`one_shot`) with the engine's ``reply`` until it asks the
    engine again (kept in ``pending``) or ends (its outputs written into ``out``)."""
    try:
        pending[i] = (shot, shot.send(reply))
    except StopIteration as done:
        for k, v in done.value.items():
            out[k][i] = v


class _Path:
    """The samples and impacts of one traced shot."""

    def __init__(self):
        self.time, self.x, self.y, self.z, self.phase = [], [], [], [], []
        self.impacts = []

    def on_rim(self, t: float, pos, on_rim: dict) -> None:
        """The rim phase from ``t`` [s] (phase 1): its start and, if the ball left, its end."""
        ends = [(t, pos)]
        if on_rim["left"] is not None:
            ends.append((t + on_rim["t_end"], on_rim["left"][0]))
        for time, (x, y, z) in ends:
            self.time.append(time)
            self.x.append(x)
            self.y.append(y)
            self.z.append(z)
            self.phase.append(1)

    def arrays(self) -> dict:
        imp = np.array(self.impacts, float).reshape(-1, 5)
        return {"time": np.array(self.time), "x": np.array(self.x), "y": np.array(self.y), "z": np.array(self.z),
                "phase": np.array(self.phase, np.int8), "impact_time": imp[:, 0], "impact_x": imp[:, 1],
                "impact_y": imp[:, 2], "impact_z": imp[:, 3], "impact_kind": imp[:, 4].astype(np.int8)}


def one_shot(release: dict, p, contact, budget: tuple[float, int], path=None, samples: int = 0, lift: bool = False):
    """A generator: one shot released as ``release`` (scalars of ``shots.RELEASE``); it yields a capture
    request (state, t_left) to the rim engine and takes the run (``shot_capture.roll_batch``'s item), and
    returns the shot's outputs (scalars)."""
    t_max, max_impacts = budget
    rho = p.r + p.a
    board = board_of(p.R, p.a)
    position, velocity, omega = release_state(**release)
    spin = tuple(float(c) for c in omega)
    flight = Flight(p, [float(c) for c in position], [float(c) for c in velocity], spin, lift)
    res = {"n_impacts": 0, "n_rim_impacts": 0, "n_board_impacts": 0, "n_double_contacts": 0, "first_contact": 0,
           "impact_kinds": 0, "time_on_rim": 0.0, "revolutions_on_rim": 0.0}
    t, last_kind, last_time = 0.0, 0, -math.inf
    while True:
        span_end = flight.time_to_depth(-rho)
        span = min(span_end, t_max - t)
        hit_t, hit_kind = _next_contact(flight, span, p, rho, board, last_kind)
        if path is not None:
            flight.sample(path, t, hit_t if hit_kind else span, samples)
        if not hit_kind:
            t += span
            x, y, _ = flight.position(span)
            if span < span_end:
                return _finish(res, t, "unfinished", "time_budget")
            return _finish(res, t, _classify(res, math.hypot(x, y) < p.R, x, y), "ok")
        if res["n_impacts"] >= max_impacts:
            return _finish(res, t + hit_t, "unfinished", "impact_budget")
        t += hit_t
        pos, vel = flight.position(hit_t), flight.velocity(hit_t)
        captured = None
        if hit_kind == RIM:
            vel, spin, captured = capture_impact(pos, vel, spin, ring_normal(*pos, p.R), p, contact)
        else:
            vel, spin, _ = impact(vel, spin, (-1.0, 0.0, 0.0), p.r, p.j, contact.e_board, contact.mu_board)
        _count(res, hit_kind, last_kind, t - last_time)
        if path is not None:
            path.impacts.append((t, *pos, hit_kind))
        last_kind, last_time = hit_kind, t
        if captured is not None:
            _record_capture(res, captured)
            on_rim = yield captured, t_max - t
            res["time_on_rim"] += on_rim["t_end"]
            res["revolutions_on_rim"] += on_rim["revolutions"]
            res["rim_outcome"] = on_rim["outcome"]
            if path is not None:
                path.on_rim(t, pos, on_rim)
            t += on_rim["t_end"]
            if on_rim["left"] is None:
                return _finish(res, t, "unfinished", "on_rim")
            pos, vel, spin = on_rim["left"]
            if _behind_board(pos, board, p.r):  # the rim phase does not see the board (docs/shots.md)
                return _finish(res, t, "unfinished", "rim_board")
            if not on_rim["separates"]:
                inside = on_rim["outcome"] == FALL_IN
                return _finish(res, t, _classify(res, inside, pos[0], pos[1]), "engine_landing")
            last_time = t
        flight = Flight(p, list(pos), list(vel), spin, lift)


def _next_contact(flight, span: float, p, rho: float, board, last_kind: int) -> tuple[float, int]:
    """(time [s] from the flight's start, kind) of its first contact within ``span`` [s]; (nan, 0) if none."""
    best_t, best_kind = math.nan, 0
    for t0, t1, i, may_ring, may_plane in flight.pieces(span):
        t_rim = t_board = math.nan
        if may_ring:
            xp, yp, zp = flight.polynomials(i)
            t_rim = first_ring_contact(xp, yp, zp, t1 - t0, p.R, rho, leaving=(last_kind == RIM and t0 == 0.0))
        if may_plane:
            t_board = first_plane_contact(flight.polynomials(i)[0], t1 - t0, board.x - p.r)
        if math.isfinite(t_board):
            _, yb, zb = flight.position(t0 + t_board)
            if not (abs(yb) <= board.half_width and board.z_low <= zb <= board.z_high):
                t_board = math.nan
        for t_hit, kind in ((t_rim, RIM), (t_board, BOARD)):
            if math.isfinite(t_hit) and not t_hit + t0 >= best_t:
                best_t, best_kind = t_hit + t0, kind
        if best_kind:
            return best_t, best_kind
    return math.nan, 0


def _behind_board(pos, board, r: float) -> bool:
    """Whether a ball of radius ``r`` [m] centred at ``pos`` [m] overlaps the board's face (more than 1e-9 m)."""
    x, y, z = pos
    return x > board.x - r + 1e-9 and abs(y) <= board.half_width and board.z_low <= z <= board.z_high


def _record_capture(res: dict, captured) -> None:
    """Keep the first capture's state (beta, omega1..3, slip) in the outputs ``res``."""
    if math.isnan(res.get("beta_cap", math.nan)):
        res.update(zip(CAPTURE_KEYS, captured[1:]))


def _count(res: dict, kind: int, last_kind: int, since_last: float) -> None:
    """Count an impact of ``kind`` in the outputs ``res``."""
    if res["n_impacts"] < KIND_DIGITS:
        res["impact_kinds"] += kind * 3 ** res["n_impacts"]
    res["n_impacts"] += 1
    res["n_rim_impacts" if kind == RIM else "n_board_impacts"] += 1
    if not res["first_contact"]:
        res["first_contact"] = kind
    if last_kind and last_kind != kind and since_last <= DOUBLE_WINDOW:
        res["n_double_contacts"] += 1


def _classify(res: dict, inside: bool, x: float, y: float) -> str:
    """The outcome name of a shot that ended at (x, y) [m] (the centre at z = -rho)."""
    if inside:
        if not res["n_impacts"]:
            return "swish"
        if not math.isnan(res.get("beta_cap", math.nan)):
            return "make_roll"
        return "make_board" if res["n_board_impacts"] else "make_rim"
    if not res["n_impacts"]:
        return "airball"
    if not res["n_rim_impacts"]:
        return "miss_board"
    if abs(x) >= abs(y):
        return "miss_short" if x < 0.0 else "miss_long"
    return "miss_left" if y > 0.0 else "miss_right"


def _finish(res: dict, t: float, outcome: str, status: str) -> dict:
    return {**res, "t_end": t, "outcome": OUTCOMES.index(outcome), "status": STATUSES.index(status)}
