"""The collision-avoidance runs of ``lpik reproduce``: the planar obstacle and the Panda's shelf.

Each scene is run with LP2 under the paper's potential field alone, the hard
distance rows alone, and both (:mod:`lpik.collision`):

* ``obstacle`` (planar, :mod:`lpik.paper.scenarios`): the pull-in past a circle
  beside the elbow's path. The field moves the elbow around it through the
  null space and the tool arrives; the rows alone keep ``d_s`` but LP2's
  criterion does not steer around, so ``p -> 0`` and ``binding`` names the
  obstacle; both together arrive and keep ``d_s``.
* ``panda-shelf``: the Panda reaches from its home configuration over a table
  into a shelf (``lpik/data/scenes/panda-shelf.json``, ``lpik simulate reach``).
"""

from __future__ import annotations

from collections.abc import Callable
from importlib.resources import files
from pathlib import Path

from lpik.collision import collision_avoidance, load_scene
from lpik.control.log import SimulationLog
from lpik.paper.reach import reach_setup
from lpik.paper.scenarios import get_scenario
from lpik.paper.setup import PAPER_COMMAND

#: The mechanisms compared, with their captions.
MECHANISMS = (
    ("field", "potential field (paper, Khatib)"),
    ("rows", "hard distance rows (velocity damper)"),
    ("both", "field and rows"),
)
#: The Panda's target inside the shelf [m], and the steps of its runs.
SHELF_TARGET = (0.72, 0.0, 0.36)
SHELF_STEPS = 200
#: Figure files written by :func:`reproduce_collision`.
COLLISION_FIGURES = ("fig11-obstacle.png", "fig12-panda-shelf.png")


def shelf_scene_path() -> Path:
    """The bundled scene of the Panda's table and shelf."""
    return Path(str(files("lpik") / "data" / "scenes" / "panda-shelf.json"))


def obstacle_runs(method: str = "lp2") -> dict[str, SimulationLog]:
    """The planar ``obstacle`` scenario under each mechanism."""
    setup = get_scenario("obstacle").setup()
    return {
        mechanism: setup.run(
            method,
            **PAPER_COMMAND,
            scene=collision_avoidance(
                setup.model, setup.scene, setup.q0, mechanism=mechanism
            ),  # fmt: skip
        )
        for mechanism, _ in MECHANISMS
    }


def shelf_runs(method: str = "lp2") -> dict[str, SimulationLog]:
    """The Panda reaching into the shelf under each mechanism."""
    setup = reach_setup("panda", SHELF_TARGET)
    scene = load_scene(shelf_scene_path())
    return {
        mechanism: setup.run(
            method,
            **PAPER_COMMAND,
            steps=SHELF_STEPS,
            scene=collision_avoidance(setup.model, scene, setup.q0, mechanism=mechanism),
        )  # fmt: skip
        for mechanism, _ in MECHANISMS
    }


def reproduce_collision(
    out_dir: str | Path, progress: Callable[[str], None] | None = None
) -> list[Path]:
    """Run both scenes under the three mechanisms; write their CSV logs and two figures."""
    from lpik.paper.collision_figures import avoidance_figure

    say = progress or (lambda _: None)
    out = Path(out_dir)
    say("obstacle (planar), lp2: field, rows, both")
    planar = obstacle_runs()
    say("panda reaching into a shelf, lp2: field, rows, both")
    shelf = shelf_runs()
    written = [log.to_csv(out / f"obstacle-lp2-{name}.csv") for name, log in planar.items()]
    written += [log.to_csv(out / f"panda-shelf-lp2-{name}.csv") for name, log in shelf.items()]
    captions = dict(MECHANISMS)
    setup = get_scenario("obstacle").setup()
    written.append(
        avoidance_figure(
            [(captions[name], log) for name, log in planar.items()],
            setup.model,
            setup.scene,
            out / COLLISION_FIGURES[0],
            target=setup.target,
            title="Fig. 11 (beyond the paper) - LP2 pulling in past an obstacle beside the elbow",
        )  # fmt: skip
    )
    reach = reach_setup("panda", SHELF_TARGET)
    written.append(
        avoidance_figure(
            [(captions[name], log) for name, log in shelf.items()],
            reach.model,
            load_scene(shelf_scene_path()),
            out / COLLISION_FIGURES[1],
            target=SHELF_TARGET,
            title="Fig. 12 (beyond the paper) - the Panda reaching over a table into a shelf (LP2)",
        )  # fmt: skip
    )
    return written
