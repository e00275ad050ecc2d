"""The figures of runs with obstacles (Figs. 11-12 of ``lpik reproduce``)."""

from __future__ import annotations

import pytest

from lpik.collision import collision_avoidance, load_scene
from lpik.paper.collision_figures import avoidance_figure
from lpik.paper.collision_runs import SHELF_TARGET, shelf_scene_path
from lpik.paper.reach import reach_setup
from lpik.paper.scenarios import get_scenario


def test_planar_and_3d_figures_are_drawn(tmp_path) -> None:  # type: ignore[no-untyped-def]
    setup = get_scenario("obstacle").setup()
    logs = [(m, setup.run("lp2", steps=20, scene=collision_avoidance(
        setup.model, setup.scene, setup.q0, mechanism=m))) for m in ("field", "rows")]  # fmt: skip
    out = avoidance_figure(logs, setup.model, setup.scene, tmp_path / "planar.png", title="t")
    assert out.stat().st_size > 10_000
    reach = reach_setup("panda", SHELF_TARGET)
    scene = load_scene(shelf_scene_path())
    log = reach.run("lp2", steps=10, scene=scene)
    out = avoidance_figure([("rows", log)], reach.model, scene, tmp_path / "panda.png", title="t")
    assert out.stat().st_size > 10_000
    with pytest.raises(ValueError, match="has no distances"):
        avoidance_figure([("none", reach.run("lp2", steps=2))], reach.model, scene,
                         tmp_path / "x.png", title="t")  # fmt: skip
