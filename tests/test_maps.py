"""Capability maps (``lpik.maps``, ``lpik map``): right values, the same on any cluster, refusals.

Tiny maps of the paper's planar arm (and two cells of the Panda), on an
in-process Dask cluster and on a two-process one, each started once for the
module. The map's p is held equal to ``lpik.solve`` on the same problem and
to independent HiGHS LPs written here from the paper's equations (scipy's
``linprog``): LP1 (eqs. 11-14) and LP2 (eq. 18); reachability to an
independent bounded least-squares IK (scipy's ``least_squares``).
"""

from __future__ import annotations

import contextlib
import io
import logging

import numpy as np
import pytest

pytest.importorskip("numba")
pytest.importorskip("zarr")
pytest.importorskip("xarray")
distributed = pytest.importorskip("distributed")

from scipy.optimize import least_squares, linprog  # noqa: E402

from lpik import build_problem, solve, standard_limits  # noqa: E402
from lpik.cli.main import main  # noqa: E402
from lpik.maps import build_map, map_robot, open_map, run_map  # noqa: E402
from lpik.maps import run as map_run  # noqa: E402
from lpik.maps.spread import spread_orientations, spread_twists  # noqa: E402
from lpik.maps.steps import BINDING_WORDS, binding_code  # noqa: E402

#: The planar maps of this module: 9 x 9 cells of 1 m around the base, 6 directions.
PLANAR = {"region": (-4.0, 4.5, -4.0, 4.5), "resolution": 1.0, "directions": 6}
SUMMARY_NAMES = ("reach_share", "p_mean", "p_min", "weakest_direction", "binding_mode")


@pytest.fixture(scope="module")
def one_worker():
    """An in-process Dask cluster of one worker thread (it also compiles the kernels first)."""
    cluster = distributed.LocalCluster(
        n_workers=1,
        threads_per_worker=1,
        processes=False,
        dashboard_address=":0",
        silence_logs=logging.ERROR,
    )
    with cluster, distributed.Client(cluster) as client:
        yield client


@pytest.fixture(scope="module")
def two_workers(one_worker):  # after one_worker: the workers load the compiled kernels
    cluster = distributed.LocalCluster(
        n_workers=2,
        threads_per_worker=1,
        processes=True,
        dashboard_address=":0",
        silence_logs=logging.ERROR,
    )
    with cluster:
        yield cluster


@pytest.fixture(scope="module")
def planar_path(one_worker, tmp_path_factory):
    out = tmp_path_factory.mktemp("maps") / "planar"
    run_map("planar", out=out, scheduler=one_worker, chunk=3, **PLANAR)
    return out


@pytest.fixture(scope="module")
def planar_map(planar_path):
    return open_map(planar_path)


def _arrays(dataset):
    return {
        name: np.asarray(dataset[name].values) for name in ("p", "binding", "q", *SUMMARY_NAMES)
    }


def _assert_same(a, b):
    for name, values in _arrays(a).items():
        other = np.asarray(b[name].values)
        assert values.dtype == other.dtype, name
        assert np.array_equal(values, other, equal_nan=values.dtype.kind == "f"), name


def _steps(dataset, model):
    """Every (cell, orientation, direction) reached: its q, the step dw and its p and code."""
    q, p, binding = (np.asarray(dataset[name].values) for name in ("q", "p", "binding"))
    twists = np.asarray(dataset["direction_twist"].values)
    rows = [("x", "y", "z", "rx", "ry", "rz").index(r) for r in model.row_names]
    scale = dataset.attrs["speed"] * dataset.attrs["dt"]
    for index in zip(*np.nonzero(~np.isnan(q[..., 0]))):
        for k, twist in enumerate(twists):
            yield q[index], scale * twist[rows], float(p[(*index, k)]), int(binding[(*index, k)])


def _bounds(model, q, dt):
    """Bounds on dq from the end-stops and velocity limits (eqs. 13-14), written out here."""
    return np.maximum(model.q_min - q, -model.qd_max * dt), np.minimum(
        model.q_max - q, model.qd_max * dt
    )


def _lp1(J, dw, lower, upper):
    """LP1 (eqs. 11-14): max p, J dq - p dw = 0, bounds on dq, 0 <= p <= 1."""
    n = J.shape[1]
    c = np.zeros(n + 1)
    c[-1] = -1.0
    done = linprog(
        c,
        A_eq=np.hstack([J, -dw[:, None]]),
        b_eq=np.zeros(len(dw)),
        bounds=[*zip(lower, upper), (0.0, 1.0)],
        method="highs",
    )
    assert done.status == 0
    return done.x[-1]


def _lp2(J, dw, lower, upper):
    """LP2 (eq. 18), M = I, f = 0: max p over (dq, lam, p), dq + J^T lam = 0, J dq - p dw = 0."""
    m, n = J.shape
    A = np.block([[np.eye(n), J.T, np.zeros((n, 1))], [J, np.zeros((m, m)), -dw[:, None]]])
    c = np.zeros(n + m + 1)
    c[-1] = -1.0
    bounds = [*zip(lower, upper), *[(None, None)] * m, (0.0, 1.0)]
    done = linprog(c, A_eq=A, b_eq=np.zeros(n + m), bounds=bounds, method="highs")
    assert done.status == 0
    return done.x[-1]


def test_the_dataset_has_the_named_variables_coordinates_and_attributes(planar_map) -> None:
    ds = planar_map
    assert ds["p"].dims == ("x", "y", "z", "orientation", "direction")
    assert ds["q"].dims == ("x", "y", "z", "orientation", "joint")
    assert ds["orientation_wxyz"].dims == ("orientation", "quaternion")
    assert ds["direction_twist"].dims == ("direction", "twist")
    assert {"orientation_wxyz", "direction_twist"} <= set(ds.coords)
    assert ds["x"].attrs["units"] == "m" and list(ds["z"].values) == [0.0]
    np.testing.assert_allclose(ds["x"].values, np.arange(-3.5, 5.0, 1.0))
    for key, value in {"dt": 0.01, "speed": 0.5, "method": "lp2s", "robot": "planar"}.items():
        assert ds.attrs[key] == value
    assert ds.attrs["status"] == "complete" and ds.attrs["reached_cells"] > 20
    twists = ds["direction_twist"].values
    np.testing.assert_allclose(np.linalg.norm(twists, axis=1), 1.0)
    assert not twists[:, 2:].any()  # the planar task: x, y only
    assert ds["binding"].attrs["flag_meanings"].split()[1:] == [
        w.replace("-", "_") for w in BINDING_WORDS
    ]


def test_the_spread_sets_are_unit_and_spread() -> None:
    twists = spread_twists(26, ("x", "y", "z", "rx", "ry", "rz"))
    assert (np.abs(twists[:13, 3:]).max(), np.abs(twists[13:, :3]).max()) == (0.0, 0.0)
    np.testing.assert_allclose(np.linalg.norm(twists, axis=1), 1.0)
    np.testing.assert_allclose(twists[:13, :3].mean(axis=0), 0.0, atol=0.05)
    quats = spread_orientations(50, ("x", "y", "z", "rx", "ry", "rz"), np.eye(3))
    np.testing.assert_allclose(np.linalg.norm(quats, axis=1), 1.0)
    closest = np.abs(quats @ quats.T - np.eye(50)).max()
    assert closest < 0.99  # no two orientations nearly the same
    with pytest.raises(ValueError, match="orientations"):
        spread_orientations(3, ("x", "y"), np.eye(3))


def test_map_p_equals_solve_and_the_lp_of_eq_18(planar_map, one_worker, tmp_path) -> None:
    model = map_robot("planar").model
    limits = standard_limits(model, lambda_bound=None)
    lp2_map = build_map(
        "planar", out=tmp_path / "lp2", scheduler=one_worker, method="lp2", **PLANAR
    )
    checked = 0
    for (q, dw, p, code), (_, _, p2, _) in zip(_steps(planar_map, model), _steps(lp2_map, model)):
        J = model.jacobian(q)
        result = solve(build_problem(J, dw, q, limits, dt=0.01), "lp2s")
        assert p == pytest.approx(result.p, abs=1e-6)
        assert code == binding_code(None if result.binding is None else result.binding.kind)
        assert p2 == pytest.approx(_lp2(J, dw, *_bounds(model, q, 0.01)), abs=1e-6)
        assert p2 <= p + 1e-6  # saturation only adds to LP2's p
        checked += 1
    assert checked > 100


def test_lp1_map_equals_solve_and_an_independent_highs_lp(one_worker, tmp_path) -> None:
    model = map_robot("planar").model
    limits = standard_limits(model, lambda_bound=None)
    options = {**PLANAR, "region": (2.0, 4.5, -4.0, 4.5), "speed": 3.0}  # the rim: p < 1
    ds = build_map("planar", out=tmp_path / "lp1", scheduler=one_worker, method="lp1", **options)
    codes = []
    for q, dw, p, code in _steps(ds, model):
        J = model.jacobian(q)
        result = solve(build_problem(J, dw, q, limits, dt=0.01), "lp1")
        assert p == pytest.approx(result.p, abs=1e-6)
        assert p == pytest.approx(_lp1(J, dw, *_bounds(model, q, 0.01)), abs=1e-6)
        assert code == binding_code(None if result.binding is None else result.binding.kind)
        codes.append(code)
    assert {binding_code(None), binding_code("velocity")} <= set(codes)


def test_a_pose_map_of_the_panda_reaches_its_poses_and_equals_solve(one_worker, tmp_path) -> None:
    robot = map_robot("panda")
    ds = build_map(
        "panda",
        (0.4, 0.5, -0.05, 0.05, 0.3, 0.3),
        0.1,
        orientations=2,
        directions=4,
        seeds=8,
        out=tmp_path / "panda",
        scheduler=one_worker,
    )
    quats = ds["orientation_wxyz"].values
    assert quats.shape == (2, 4) and ds["direction_twist"].values[2:, :3].any() == 0
    limits = standard_limits(robot.model, lambda_bound=None)
    q = ds["q"].values
    assert (~np.isnan(q[..., 0])).sum() >= 2
    for index in zip(*np.nonzero(~np.isnan(q[..., 0]))):
        pose = robot.chain.fk(q[index])
        centre = [float(ds[a].values[i]) for a, i in zip("xyz", index[:3])]
        np.testing.assert_allclose(pose[:3, 3], centre, atol=2e-6)
        assert (q[index] >= robot.model.q_min).all() and (q[index] <= robot.model.q_max).all()
    for q0, dw, p, _ in _steps(ds, robot.model):
        result = solve(build_problem(robot.model.jacobian(q0), dw, q0, limits, dt=0.01), "lp2s")
        assert p == pytest.approx(result.p, abs=1e-6)


def test_reachability_agrees_with_an_independent_ik(planar_map) -> None:
    """Least squares within the end-stops from 8 seeds, on cells off the rim, reached or not."""
    model = map_robot("planar").model
    rng = np.random.default_rng(7)
    reached = ~np.isnan(planar_map["q"].values[:, :, 0, 0, 0])
    x, y = np.meshgrid(planar_map["x"].values, planar_map["y"].values, indexing="ij")
    off_rim = np.abs(np.hypot(x, y) - 4.0) > 0.2  # near the 4 m reach either may stop short
    picked = [*np.argwhere(reached & off_rim)[::6], *np.argwhere(~reached & off_rim)[:4]]
    assert len(picked) > 8
    for i, j in picked:
        found = False
        for seed in rng.uniform(model.q_min, model.q_max, (8, 4)):
            point = (x[i, j], y[i, j])
            fit = least_squares(
                lambda q, point=point: model.kinematics.fk(q)[:2, 3] - point,
                seed,
                bounds=(model.q_min, model.q_max),
            )
            if np.abs(fit.fun).max() < 1e-6:
                found = True
                break
        assert found == reached[i, j], (x[i, j], y[i, j])


def test_one_and_two_workers_and_any_chunks_give_the_same_map(
    planar_map, two_workers, tmp_path
) -> None:
    other = build_map(
        "planar", out=tmp_path / "two", scheduler=two_workers.scheduler_address, chunk=4, **PLANAR
    )
    assert other.attrs["chunks"] != planar_map.attrs["chunks"]
    _assert_same(planar_map, other)


def test_an_interrupted_map_resumes_to_the_same_map(planar_map, one_worker, tmp_path) -> None:
    out = tmp_path / "resumed"

    def stop_after_two(done: int, total: int) -> None:
        if done == 2:
            raise KeyboardInterrupt

    with pytest.raises(KeyboardInterrupt):
        run_map("planar", out=out, scheduler=one_worker, chunk=3, progress=stop_after_two, **PLANAR)
    partial = open_map(out)
    assert partial.attrs["status"] == "incomplete"
    assert 2 <= int(partial["block_done"].values.sum()) < 9
    run = run_map("planar", out=out, scheduler=one_worker, chunk=5, **PLANAR)
    assert run.resumed >= 2 and run.blocks == 9  # the store's blocks, whatever chunk says
    _assert_same(planar_map, open_map(out))
    with pytest.raises(ValueError, match=r"out: .* other options \(resolution 1\.0 there, 0\.5"):
        run_map("planar", out=out, scheduler=one_worker, **{**PLANAR, "resolution": 0.5})


def test_a_region_too_large_is_refused_before_any_work(tmp_path) -> None:
    out = tmp_path / "huge"
    with pytest.raises(ValueError, match=r"region: the map .* needs up to [\d,.]+ GB on disk"):
        run_map("panda", (-50, 50, -50, 50, 0, 10), 0.001, orientations=50, directions=26, out=out)
    assert not out.exists()


@pytest.mark.parametrize(
    ("options", "message"),
    [({"resolution": 1e-300}, r"resolution: 1e\+300 cells along x, more than 100,000"),
     ({"region": (0, 1e200, 0, 1, 0, 1)}, r"resolution: 2e\+200 cells along x"),
     ({"speed": 1e200}, r"speed: must be > 0 \(at most 1e\+12\), got 1e\+200"),
     ({"dt": 2.0}, r"dt: must be > 0 \(at most 1\), got 2\.0")],
)  # fmt: skip
def test_a_grid_or_a_step_too_large_is_named_before_any_work(tmp_path, options, message) -> None:  # type: ignore[no-untyped-def]
    """A resolution of 1e-300 m overflowed the count of cells (an OverflowError); a speed
    or period of 1e200 was named only as the step's internal ``dw``."""
    out = tmp_path / "map"
    arguments = {"region": (0, 1, 0, 1, 0, 1), "resolution": 0.5, **options}
    with pytest.raises(ValueError, match=f"^{message}"):
        run_map("panda", out=out, **arguments)
    assert not out.exists()


def _lpik(*args: str) -> tuple[int, str, str]:
    out, err = io.StringIO(), io.StringIO()
    with contextlib.redirect_stdout(out), contextlib.redirect_stderr(err):
        status = main(list(args))
    return status, out.getvalue(), err.getvalue()


def test_the_command_maps_on_a_scheduler_and_says_when_the_map_is_empty(
    two_workers, tmp_path
) -> None:
    address = two_workers.scheduler_address
    figure = tmp_path / "slice.png"
    status, out, err = _lpik(
        "map",
        "--robot",
        "planar",
        "--region=-4,4.5,-4,4.5",
        "--resolution",
        "1",
        "--out",
        str(tmp_path / "m"),
        "--scheduler",
        address,
        "--figure",
        str(figure),
    )
    assert status == 0, err
    assert " of 81 cells reached" in out and "binding most often" in out
    assert figure.stat().st_size > 10_000
    status, out, err = _lpik(
        "map",
        "--robot",
        "planar",
        "--region=6,8,6,8",
        "--resolution",
        "1",
        "--out",
        str(tmp_path / "empty"),
        "--scheduler",
        address,
    )
    assert status == 0, err
    assert "0 of 4 cells reached" in out and "the map is empty" in out
    assert open_map(tmp_path / "empty").attrs["reached_cells"] == 0


def test_an_unreachable_scheduler_is_one_line_and_exit_2(tmp_path, monkeypatch) -> None:
    monkeypatch.setattr(map_run, "CONNECT_TIMEOUT_S", 1.0)
    status, out, err = _lpik(
        "map",
        "--robot",
        "planar",
        "--region=0,1,0,1",
        "--resolution",
        "1",
        "--out",
        str(tmp_path / "m"),
        "--scheduler",
        "tcp://127.0.0.1:9",
    )
    assert status == 2 and out == ""
    assert err.count("\n") == 1 and "--scheduler: cannot reach 'tcp://127.0.0.1:9'" in err


def test_a_store_that_cannot_be_made_names_out(tmp_path) -> None:
    """The operating system's error alone ('Not a directory') did not say which option."""
    blocker = tmp_path / "a-file"
    blocker.write_text("")
    out = str(blocker / "map")
    status, _, err = _lpik("map", "--robot", "planar", "--region=0,1,0,1", "--resolution", "1",
                           "--out", out, "--workers", "1")  # fmt: skip
    assert status == 2
    assert err.count("\n") == 1 and err.startswith(f"lpik: error: --out: cannot write {out!r}")


def test_base_placement_ranks_the_bases_by_the_weakest_task_row(two_workers, tmp_path) -> None:
    task = tmp_path / "task.csv"
    task.write_text("x,y,vx,vy,vz,wx,wy,wz\n5,0,1,0,0,0,0,0\n5,1,0,1,0,0,0,0\n")
    status, out, err = _lpik(
        "map",
        "--robot",
        "planar",
        "--place",
        str(task),
        "--region=0,6,-2,2",
        "--resolution",
        "1",
        "--speed",
        "3",
        "--out",
        str(tmp_path / "p"),
        "--placements",
        str(tmp_path / "best.csv"),
        "--scheduler",
        two_workers.scheduler_address,
        "--figure",
        str(tmp_path / "place.png"),
    )
    assert status == 0, err
    rows = (tmp_path / "best.csv").read_text().splitlines()
    assert rows[0] == "rank,x,y,z,score,reached,p_mean,weakest_row" and len(rows) == 11
    scores = [float(r.split(",")[4]) for r in rows[1:]]
    assert scores == sorted(scores, reverse=True) and scores[0] > 0.5
    best_x = float(rows[1].split(",")[1])
    assert 1.0 < best_x < 5.0  # the task at x = 5 within the 4 m reach
    ds = open_map(tmp_path / "p")
    assert ds.attrs["kind"] == "base placement" and ds["task_position"].shape == (2, 3)
    assert "best base position" in out and (tmp_path / "place.png").exists()


class _Scene:
    """A viser scene that records what is added to it."""

    def __init__(self) -> None:
        self.added: dict[str, dict] = {}

    def add_batched_meshes_simple(self, name, **kwargs):
        self.added[name] = kwargs

    def add_line_segments(self, name, points, colors, **kwargs):
        self.added[name] = {"points": points, "colors": colors, **kwargs}


def test_the_console_draws_the_map_as_voxels_coloured_by_p(
    planar_path, planar_map, tmp_path
) -> None:
    from lpik.console.map_layer import add_map_layer, map_voxels, p_colour

    layer = map_voxels(planar_path)
    share = planar_map["reach_share"].values
    assert len(layer.centres) == int((share > 0).sum()) and layer.edge == 1.0
    assert (layer.centres[:, 2] == 0.0).all()
    p_min = planar_map["p_min"].values
    i = np.argwhere(share > 0)[0]
    at = np.flatnonzero(
        (layer.centres == [planar_map[a].values[k] for a, k in zip("xyz", i)]).all(1)
    )
    assert (layer.colours[at[0]] == p_colour(p_min[tuple(i)])).all()
    weak = int((planar_map["weakest_direction"].values >= 0).sum())
    assert len(layer.segments) == weak and weak > 0
    scene = _Scene()
    add_map_layer(scene, layer)
    assert scene.added["/map/voxels"]["batched_positions"].shape == (len(layer.centres), 3)
    assert scene.added["/map/weakest"]["points"].shape == (weak, 2, 3)
    assert scene.added["/map/weakest"]["colors"].shape == (weak, 2, 3)  # as viser takes them
    (tmp_path / "nomap").mkdir()
    (tmp_path / "nomap" / "x").write_text("")
    with pytest.raises(ValueError, match="--map: .* is no map"):
        map_voxels(tmp_path / "nomap")
    assert p_colour(np.array([0.0, 1.0])).tolist() == [[220, 0, 40], [0, 190, 40]]
