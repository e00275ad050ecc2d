"""``lpik simulate ... --scene SCENE.json [--avoid rows|field|both]``."""

from __future__ import annotations

import csv
import json

import pytest

from lpik.cli.main import main

SCENE = {
    "obstacles": [{"name": "ball", "type": "sphere", "center": [0.8, 2.0], "radius": 0.15}],
    "safety_distance": 0.05,
    "influence_distance": 0.3,
}


@pytest.mark.parametrize("avoid", ["rows", "both"])
def test_a_run_with_a_scene_writes_min_distance_and_closest(tmp_path, capsys, avoid) -> None:  # type: ignore[no-untyped-def]
    scene, out = tmp_path / "scene.json", tmp_path / "run.csv"
    scene.write_text(json.dumps(SCENE))
    args = ["simulate", "pull-in", "--scene", str(scene), "--avoid", avoid, "--steps", "250"]
    assert main([*args, "--out", str(out)]) == 0
    rows = list(csv.DictReader(out.open(encoding="utf-8")))
    # the scene's two columns, then the log's last: the share of sec. 3.1's pull each step took
    assert list(rows[0])[-3:] == ["min_distance", "closest", "pull_scale"]
    assert all(0.0 <= float(r["pull_scale"]) <= 1.0 for r in rows)
    assert min(float(r["min_distance"]) for r in rows) >= 0.05 - 1e-3
    assert {r["closest"] for r in rows} <= {f"link {i} - ball" for i in range(1, 5)} | {
        "link 1 - link 3", "link 1 - link 4", "link 2 - link 4"}  # fmt: skip


@pytest.mark.parametrize(
    ("scene", "message"),
    [
        ("{", "scene: unreadable JSON"),
        (json.dumps({**SCENE, "safety_distance": -1}), "safety_distance: must be a finite number"),
        (json.dumps({**SCENE, "obstacles": [{"name": "b", "type": "sphere", "radius": 1}]}),
         "obstacles[0].center: missing"),
    ],
)  # fmt: skip
def test_a_bad_scene_is_one_line_and_exit_2(tmp_path, capsys, scene, message) -> None:  # type: ignore[no-untyped-def]
    path = tmp_path / "scene.json"
    path.write_text(scene)
    assert main(["simulate", "pull-in", "--scene", str(path), "--steps", "5"]) == 2
    err = capsys.readouterr().err
    assert message in err and err.count("\n") == 1 and "Traceback" not in err


def test_reach_moves_the_panda_into_the_shelf_keeping_its_distance(tmp_path, capsys) -> None:  # type: ignore[no-untyped-def]
    from importlib.resources import files

    scene = files("lpik") / "data" / "scenes" / "panda-shelf.json"
    out = tmp_path / "reach.csv"
    args = ["simulate", "reach", "--robot", "panda", "--target", "0.72,0,0.36"]
    assert main([*args, "--scene", str(scene), "--steps", "150", "--out", str(out)]) == 0
    rows = list(csv.DictReader(out.open(encoding="utf-8")))
    end = [float(rows[-1][k]) for k in "xyz"]
    assert end == pytest.approx([0.72, 0.0, 0.36], abs=2e-3)
    assert min(float(r["min_distance"]) for r in rows) >= 0.02 - 1e-3
    assert any(r["binding"].startswith("collision panda_link") for r in rows)


def test_the_obstacle_scenario_carries_its_scene(tmp_path, capsys) -> None:  # type: ignore[no-untyped-def]
    out = tmp_path / "obstacle.csv"
    assert (
        main(["simulate", "obstacle", "--avoid", "rows", "--steps", "400", "--out", str(out)]) == 0
    )
    rows = list(csv.DictReader(out.open(encoding="utf-8")))
    assert rows[-1]["binding"].endswith("- obstacle") and float(rows[-1]["p"]) < 0.05
    assert min(float(r["min_distance"]) for r in rows) >= 0.05 - 1e-3


@pytest.mark.parametrize(
    ("args", "message"),
    [
        (["reach", "--robot", "panda"], "--target: reach needs"),
        (["reach", "--robot", "panda", "--target", "1,x,2"], "--target: must be numbers"),
        (["reach", "--robot", "panda", "--target", "1,2"], "--target: a 3-D arm needs"),
        (["pull-in", "--target", "1,2,3"], "--target: only for the scenario 'reach'"),
        (["obstacle", "--robot", "panda"], "robot: scenario 'obstacle' runs on the 'planar'"),
        (
            ["obstacle", "--method", "lp1", "--avoid", "field"],
            "scene: method 'lp1' does not take the potential field's force",
        ),
        (
            ["obstacle", "--method", "nlp", "--avoid", "both"],
            "scene: method 'nlp' does not take the potential field's force",
        ),
    ],
)
def test_bad_reach_options_are_one_line(capsys, args, message) -> None:  # type: ignore[no-untyped-def]
    assert main(["simulate", *args]) == 2
    err = capsys.readouterr().err
    assert message in err and err.count("\n") == 1


def test_without_coal_a_scene_says_how_to_install_it(monkeypatch, capsys) -> None:  # type: ignore[no-untyped-def]
    import sys

    monkeypatch.setitem(sys.modules, "coal", None)
    assert main(["simulate", "obstacle", "--steps", "3"]) != 0
    err = capsys.readouterr().err
    assert 'pip install "lpik[collision]"' in err and err.count("\n") == 1


@pytest.mark.parametrize(
    ("kwargs", "message"),
    [
        ({"radii": -1.0}, "radii: the radius of link"),
        ({"radii": {"link 1": float("nan")}}, "radii: the radius of link 'link 1'"),
        ({"approach_speed": 0.0}, "approach_speed:"),
        ({"field_gain": -1.0}, "field_gain:"),
    ],
)
def test_bad_avoidance_parameters_name_themselves(kwargs, message) -> None:  # type: ignore[no-untyped-def]
    from lpik.collision import collision_avoidance, scene_from_dict
    from lpik.robots.planar import planar_arm

    scene = scene_from_dict({**SCENE})
    with pytest.raises(ValueError, match="^" + message.replace("(", r"\(")):
        collision_avoidance(planar_arm([1.0] * 4), scene, None, **kwargs)


def test_a_run_with_a_scene_draws_its_obstacles_and_reports_the_closest_pair(
    tmp_path, capsys
) -> None:  # type: ignore[no-untyped-def]
    fig = tmp_path / "run.png"
    assert main(["simulate", "obstacle", "--steps", "60", "--plot", str(fig)]) == 0
    out = capsys.readouterr().out
    assert "smallest distance" in out and "- obstacle)" in out
    assert fig.stat().st_size > 10_000


def test_a_bundled_scene_is_named_without_a_path(tmp_path) -> None:  # type: ignore[no-untyped-def]
    from importlib.resources import files

    path = str(files("lpik") / "data" / "scenes" / "panda-shelf.json")
    args = ["simulate", "reach", "--robot", "panda", "--target", "0.72,0,0.36", "--steps", "5"]
    runs = []
    for scene in ("panda-shelf", "panda-shelf.json", path):
        out = tmp_path / "reach.csv"
        assert main([*args, "--scene", scene, "--out", str(out)]) == 0
        rows = list(csv.DictReader(out.open(encoding="utf-8")))
        runs.append([(r["min_distance"], r["closest"]) for r in rows])
    assert runs[0] == runs[1] == runs[2] and len(runs[0]) == 5


def test_an_unknown_scene_name_lists_the_bundled_ones(capsys) -> None:  # type: ignore[no-untyped-def]
    assert main(["simulate", "pull-in", "--scene", "kitchen", "--steps", "5"]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "'kitchen'" in err and "panda-shelf" in err


def test_names_with_newlines_or_terminal_escapes_are_printed_escaped(tmp_path, capsys) -> None:  # type: ignore[no-untyped-def]
    name = "ba\nll\x1b[31m\u202e"
    scene = tmp_path / "scene.json"
    obstacle = {**SCENE["obstacles"][0], "name": name}
    scene.write_text(json.dumps({**SCENE, "obstacles": [obstacle]}))
    out = tmp_path / "run.csv"
    args = ["simulate", "pull-in", "--scene", str(scene), "--steps", "250", "--out", str(out)]
    assert main(args) == 0
    printed = capsys.readouterr().out
    assert printed.count("\n") == 2  # the summary and "wrote"
    assert "\x1b" not in printed and "\u202e" not in printed
    assert "ba\\nll\\x1b[31m\\u202e" in printed
    rows = list(csv.DictReader(out.open(encoding="utf-8", newline="")))
    assert any(r["closest"] == f"link 2 - {name}" for r in rows)  # the CSV keeps the name


@pytest.mark.parametrize("method", ["pinv", "lp1", "l1", "nlp"])
def test_a_field_with_a_method_that_drops_it_is_refused(method) -> None:  # type: ignore[no-untyped-def]
    """Those methods ignore ``f``: the field would be dropped without a word and the arm
    left unguarded (lp1 on the planar obstacle: a pair 5 mm inside ``d_s``)."""
    from lpik.collision import collision_avoidance, scene_from_dict
    from lpik.command import ClampedTarget
    from lpik.control.simulate import simulate
    from lpik.robots.planar import planar_arm

    model, target, q0 = planar_arm([1.0] * 4), ClampedTarget([1.0, 1.0, 0.0]), [0.3] * 4
    for mechanism in ("field", "both"):
        avoid = collision_avoidance(model, scene_from_dict(SCENE), None, mechanism=mechanism)
        with pytest.raises(ValueError, match=f"^scene: method '{method}' does not take"):
            simulate(model, target, q0, 2, method=method, dt=0.01, scene=avoid)
    rows = collision_avoidance(model, scene_from_dict(SCENE), None, mechanism="rows")
    simulate(model, target, q0, 2, method=method, dt=0.01, scene=rows)  # the rows: taken
