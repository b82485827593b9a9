"""``study trace`` of one shot: ``--release`` or a point of a ``shot`` map; the path before the first
impact is the vacuum parabola (closed form), the figure's texts stay inside it, bad input is one line."""

from __future__ import annotations

import math

import numpy as np
import pytest
import xarray as xr
from matplotlib.backends.backend_agg import FigureCanvasAgg

shots = pytest.importorskip("rimroll.solver.shots", reason="the solver's shot model is not installed")

from rimroll.study import shot_trace  # noqa: E402
from rimroll.study.cli import main  # noqa: E402

G = 9.81


def _trace(out, *args, name="trace"):
    assert main(["trace", *args, "--out", str(out), "--name", name]) == 0
    return xr.open_dataset(out / f"{name}.nc")


@pytest.fixture(scope="module")
def rim_shot(tmp_path_factory):
    """A free throw a little long of the centre at 52 deg: it touches the rim."""
    return _trace(tmp_path_factory.mktemp("trace"), "--release", "speed=7.25,angle=52")


def test_the_path_before_the_first_impact_is_the_vacuum_parabola(rim_shot):
    """x(t) = -L + v cos(theta) t, y = 0, z(t) = -h + v sin(theta) t - g t^2 / 2 (no air), up to the
    first impact, which lies at a distance rho = r + a from the ring's centre circle."""
    t = rim_shot["time"].values
    first = float(rim_shot["impact_time"].values[0])
    before = t < first
    v, theta = 7.25, math.radians(52.0)
    np.testing.assert_allclose(rim_shot["x"].values[before], -4.19 + v * math.cos(theta) * t[before], atol=1e-9)
    np.testing.assert_allclose(rim_shot["z"].values[before], -0.92 + v * math.sin(theta) * t[before]
                               - 0.5 * G * t[before] ** 2, atol=1e-9)
    np.testing.assert_allclose(rim_shot["y"].values[before], 0.0, atol=1e-12)
    kind = int(rim_shot["impact_kind"].values[0])
    assert kind == 1  # the rim
    x, y, z = (float(rim_shot[f"impact_{k}"].values[0]) for k in "xyz")
    p = shots.params_for("paper")
    assert math.hypot(math.hypot(x, y) - p.R, z) == pytest.approx(p.r + p.a, abs=1e-9)


def test_trace_of_a_map_point_is_that_shot(tmp_path):
    """FILE --at speed=..,angle=.. traces the grid point nearest to it with the file's settings: its
    outcome is the map's there."""
    assert main(["run", "shot", "--quick", "--out", str(tmp_path), "--no-progress", "--set", "e_rim=0.5"]) == 0
    ds = xr.open_dataset(tmp_path / "shot.nc")
    i, j = 12, 10
    speed, angle = float(ds["speed"][i]), float(ds["angle"][j])
    tr = _trace(tmp_path, str(tmp_path / "shot.nc"), "--at", f"speed={speed + 1e-4},angle={angle}", name="point")
    assert tr.attrs["release_speed"] == speed and tr.attrs["release_angle"] == angle
    assert tr.attrs["setting_e_rim"] == 0.5
    assert tr.attrs["outcome"] == int(ds["outcome"].isel(speed=i, angle=j))


def test_figure_texts_stay_inside(rim_shot):
    fig = shot_trace.figure(rim_shot)
    FigureCanvasAgg(fig).draw()
    box = fig.bbox
    texts = [fig._suptitle, *[t for leg in fig.legends for t in leg.get_texts()]]
    for ax in fig.axes:
        texts += [ax.title, ax.xaxis.label, ax.yaxis.label]
        assert "[m]" in ax.get_xlabel() and "[m]" in ax.get_ylabel()
    for t in texts:
        b = t.get_window_extent()
        assert box.x0 <= b.x0 and b.x1 <= box.x1 and box.y0 <= b.y0 and b.y1 <= box.y1, t.get_text()


@pytest.mark.parametrize("args, words", [
    (["--release", "speed=7.2"], "angle"),
    (["--release", "speed=-1,angle=52"], "speed"),
    (["--release", "speed=7,angle=95"], "angle"),
    (["--release", "speed=7,angle=52,spin=3"], "spin"),
    (["--release", "speed=7,angle=52", "--set", "e_rim=2"], "e_rim"),
    (["--release", "speed=7,angle=52", "--set", "geometry=nba"], "geometry"),
    (["--release", "speed=7,angle=52", "--set", "R=0.3"], "geometry"),
    (["--release", "speed=7,angle=52", "--at", "speed=7"], "--at"),
])
def test_bad_release_is_one_line_and_exit_2(tmp_path, capsys, args, words):
    code = main(["trace", *args, "--out", str(tmp_path)])
    err = capsys.readouterr().err.strip()
    assert code == 2 and "\n" not in err and words in err, err
