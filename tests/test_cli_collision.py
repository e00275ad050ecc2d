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
    assert list(rows[0])[-2:] == ["min_distance", "closest"]
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
