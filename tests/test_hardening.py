"""Hostile and careless input: every case is refused early, in one line that names the input."""

from __future__ import annotations

import json
import re
import subprocess
import sys
import warnings
from pathlib import Path

import numpy as np
import pytest

from cli_documents import GOOD as CLI_GOOD
from cli_documents import LPIK
from lpik import problem_json
from lpik.cli import simulate as simulate_cli
from lpik.cli.main import main
from lpik.exceptions import InvalidProblemError
from lpik.methods import solve
from lpik.methods.registry import METHODS
from lpik.problem import Problem
from lpik.tolerances import MAX_MAGNITUDE

ROOT = Path(__file__).resolve().parents[1]
#: The shared good document without step bounds.
GOOD = {key: value for key, value in CLI_GOOD.items() if not key.startswith("dq_")}
PROBLEM_ONLY = [name for name, spec in METHODS.items() if not spec.needs_model]


def doc(**changes: object) -> str:
    return json.dumps({**GOOD, **changes})


def run_solve(tmp_path: Path, text: str, capsys) -> tuple[int, str, str]:  # type: ignore[no-untyped-def]
    path = tmp_path / "problem.json"
    path.write_text(text, encoding="utf-8")
    code = main(["solve", str(path)])
    out, err = capsys.readouterr()
    return code, out, err


def assert_refused(code: int, out: str, err: str, key: str) -> str:
    assert code == 2, err
    assert out == ""
    lines = err.splitlines()
    assert len(lines) == 1, err
    assert lines[0].startswith(f"lpik: error: {key}: "), lines[0]
    return lines[0]


# --- lpik solve: the document ------------------------------------------------------------------

BIG_INT = "1" + "0" * 400
HOSTILE = [
    ("deep-nesting", "[" * 100_000 + "]" * 100_000, "problem", "MAX_JSON_DEPTH"),
    ("deep-in-a-key", doc().replace('"dw": [', '"dw": ' + "[" * 20, 1) + "]" * 19, "dw", "8"),
    ("integer-10**400", doc().replace('"dw": [-0.005', f'"dw": [{BIG_INT}'), "dw", "float64"),
    ("integer-5000-digits", doc().replace('"q0": [1.047', '"q0": [' + "9" * 5000), "q0", ""),
    ("float-1e400", doc().replace('"q_max": [1.658', '"q_max": [1e400'), "q_max", "float64"),
    ("numeric-string", doc(dw=["1.0", 0.0]), "dw", "string"),
    ("boolean", doc(dw=[True, 0.0]), "dw", "true"),
    ("boolean-k", doc(method="robust", k=False), "k", "false"),
    ("string-k", doc(method="robust", k="0.1"), "k", "string"),
    ("object-in-a-vector", doc(q0=[{"a": 1}, 0, 0, 0]), "q0", "object"),
    ("J-null", doc(J=None), "J", "list of rows"),
    ("label-not-a-string", doc(G=[[1, 0, 0, 0]], h=[1], row_labels=[3]), "row_labels", "string"),
    ("J-scaled-by-1e200", doc(J=[[1e200, 0, 0, 0], [0, 1e200, 0, 0]]), "J", "1e+12"),
    ("bound-1e30", doc(q_max=[1e30, 1, 1, 1]), "q_max", "null or inf"),
    ("k-1e200", doc(method="robust", k=1e200), "k", "1e+12"),
    ("too-many-joints", doc(J=[[0.0] * 129] * 2, q0=[0.0] * 129), "J", "MAX_JOINTS"),
    ("too-many-task-rows", doc(J=[[1.0, 0, 0, 0]] * 49), "J", "MAX_TASK_ROWS"),
    ("too-many-extra-rows", doc(G=[[0.0] * 4] * 129, h=[1.0] * 129), "G", "MAX_EXTRA_ROWS"),
]


@pytest.mark.parametrize(
    ("text", "key", "says"), [c[1:] for c in HOSTILE], ids=[c[0] for c in HOSTILE]
)
def test_hostile_documents_are_one_line_naming_the_key(tmp_path, capsys, text, key, says) -> None:  # type: ignore[no-untyped-def]
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        line = assert_refused(*run_solve(tmp_path, text, capsys), key)
    assert says in line


@pytest.mark.parametrize("indent", ["-1", "100000000"])
def test_solve_refuses_an_indent_out_of_range(capsys, indent: str) -> None:  # type: ignore[no-untyped-def]
    code = main(["solve", "--example", "pull-in-step", "--indent", indent])
    assert_refused(code, *capsys.readouterr(), "--indent")


def test_a_file_over_the_size_cap_is_refused_before_it_is_read(tmp_path, capsys) -> None:  # type: ignore[no-untyped-def]
    text = doc() + " " * problem_json.MAX_FILE_BYTES
    line = assert_refused(*run_solve(tmp_path, text, capsys), "problem")
    assert "MAX_FILE_BYTES" in line and str(problem_json.MAX_FILE_BYTES) in line


def test_standard_input_is_read_up_to_the_cap_only(monkeypatch, capsys) -> None:  # type: ignore[no-untyped-def]
    class Endless:
        """A stdin that never ends: reading it all would never return."""

        def __init__(self) -> None:
            self.asked: list[int] = []

        def read(self, size: int = -1) -> bytes:
            assert size > 0, "stdin must be read with a limit"
            self.asked.append(size)
            return b" " * size

    stream = Endless()
    monkeypatch.setattr(sys, "stdin", type("Stdin", (), {"buffer": stream})())
    assert_refused(main(["solve", "-"]), *capsys.readouterr(), "problem")
    assert stream.asked == [problem_json.MAX_FILE_BYTES + 1]


def test_the_largest_problem_the_caps_allow_solves_with_every_method(tmp_path, capsys) -> None:  # type: ignore[no-untyped-def]
    n, m, r = problem_json.MAX_JOINTS, problem_json.MAX_TASK_ROWS, problem_json.MAX_EXTRA_ROWS
    rng = np.random.default_rng(0)
    A = rng.standard_normal((n, n))
    data = {
        "J": rng.standard_normal((m, n)).tolist(),
        "dw": (0.01 * rng.standard_normal(m)).tolist(),
        "q0": [0.0] * n,
        "q_min": [-1.0] * n,
        "q_max": [1.0] * n,
        "dq_min": [-0.1] * n,
        "dq_max": [0.1] * n,
        "M": (A @ A.T / n + np.eye(n)).tolist(),
        "Lambda": [0.1] * n,
        "G": rng.standard_normal((r, n)).tolist(),
        "h": [10.0] * r,
    }
    text = json.dumps({"method": "lp2", **data})
    assert len(text.encode()) <= problem_json.MAX_FILE_BYTES
    path = tmp_path / "largest.json"
    for method in PROBLEM_ONLY:
        path.write_text(json.dumps({"method": method, **data}), encoding="utf-8")
        assert main(["solve", str(path)]) == 0, method
        assert len(json.loads(capsys.readouterr().out)["q"]) == n


def test_the_readme_quotes_the_caps() -> None:
    text = (ROOT / "README.md").read_text(encoding="utf-8")
    values = {
        "MAX_FILE_BYTES": problem_json.MAX_FILE_BYTES,
        "MAX_JSON_DEPTH": problem_json.MAX_JSON_DEPTH,
        "MAX_JOINTS": problem_json.MAX_JOINTS,
        "MAX_TASK_ROWS": problem_json.MAX_TASK_ROWS,
        "MAX_EXTRA_ROWS": problem_json.MAX_EXTRA_ROWS,
        "MAX_MAGNITUDE": MAX_MAGNITUDE,
    }
    for name, value in values.items():
        row = re.search(rf"^\|[^|\n]*\| ([0-9.e+]+)[^|\n]*\| `{name}` \|$", text, re.M)
        assert row, f"README: no row for {name} in the caps table of lpik solve"
        assert float(row.group(1)) == value, name


def test_the_real_command_refuses_deep_json_without_a_traceback(tmp_path) -> None:
    path = tmp_path / "deep.json"
    path.write_text("[" * 100_000, encoding="utf-8")
    run = subprocess.run(
        [str(LPIK), "solve", str(path)], capture_output=True, text=True, check=False, timeout=60
    )
    assert run.returncode == 2 and run.stdout == ""
    assert run.stderr.count("\n") == 1 and run.stderr.startswith("lpik: error: problem:")


# --- Problem: the size of its numbers ----------------------------------------------------------


def at_cap_problems() -> list[tuple[str, dict]]:
    """Problems with data at MAX_MAGNITUDE, field by field and all at once."""
    C = MAX_MAGNITUDE
    n = 4
    sign = np.array([[1.0, -1.0, 1.0, 1.0], [-1.0, 1.0, 1.0, -1.0]])
    base = {"J": sign, "dw": [0.1, -0.1], "q0": np.zeros(n)}
    full = {"q_min": np.full(n, -C), "q_max": np.full(n, C)}
    return [
        ("J", {**base, "J": C * sign}),
        ("J rank 1", {**base, "J": C * np.ones((2, n))}),
        ("dw", {**base, "dw": [C, -C]}),
        ("q0 and bounds", {**base, "q0": np.full(n, C / 2), **full}),
        ("step bounds", {**base, "dq_min": np.full(n, -C), "dq_max": np.full(n, C)}),
        ("M f", {**base, "M": np.full(n, C), "f": np.full(n, -C)}),
        ("Lambda q_ref", {**base, "Lambda": np.full(n, C), "q_ref": np.full(n, -C)}),
        ("G h", {**base, "G": C * np.ones((1, n)), "h": [-C]}),
        ("multipliers", {**base, "lam_min": [-C, -C], "lam_max": [C, C]}),
        ("J dw M", {**base, "J": C * sign, "dw": [C, -C], "M": np.full(n, C)}),
    ]


@pytest.mark.parametrize("method", PROBLEM_ONLY)
def test_no_method_warns_at_the_largest_magnitude(method: str) -> None:
    for label, fields in at_cap_problems():
        extra = [{}, {"k": MAX_MAGNITUDE}] if method == "robust" else [{}]
        for more in extra:
            with warnings.catch_warnings():
                warnings.simplefilter("error")
                result = solve(Problem(**fields, **more), method)
            assert 0.0 <= result.p <= 1.0, (label, more)
            assert np.isfinite(result.q).all(), (label, more)


@pytest.mark.parametrize("method", PROBLEM_ONLY)
@pytest.mark.parametrize("scale", [1e-300, 1e-200, 1e-160])
def test_no_method_warns_at_vanishing_magnitudes(method: str, scale: float) -> None:
    """A Jacobian whose entries' squares underflow: the task cannot move (p = 0 or a
    singular status), never a RuntimeWarning or a non-finite step (SINGULAR_FLOOR)."""
    J = scale * np.array([[1.0, 0.5, 0.25], [0.0, 1.0, 0.5]])
    problem = Problem(J=J, dw=[0.01, 0.02], q0=np.zeros(3), dq_min=-np.ones(3),
                      dq_max=np.ones(3), Lambda=[0.1] * 3, q_ref=[0.2, 0.0, -0.2])  # fmt: skip
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        result = solve(problem, method)
    assert 0.0 <= result.p <= 1.0 and np.isfinite(result.q).all()
    assert result.status != "check_failed"


def test_the_braking_command_does_not_warn_where_a_joint_hardly_moves() -> None:
    """A joint whose motion per unit of error is subnormal bounds neither the braking rate nor
    the speed (its quotient would overflow): the same share on both paths, no warning (a
    find of tests/test_recovery.py's hypothesis test in a fresh clone)."""
    from lpik.command import braking_scale
    from lpik.fast.command_law import braking_scale as compiled_braking_scale

    motion = np.array([1e-310, 0.5, 0.0])
    qdd_max, qd_max = np.array([10.0, 10.0, 10.0]), np.array([2.0, 2.0, 2.0])
    hold = np.array([-1e-7, 0.0, 0.0])  # joint 0's own motion slows it down: no room left
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        share = braking_scale(motion, hold, qdd_max, qd_max, 1e-3)
    assert share == compiled_braking_scale(motion, hold, qdd_max, qd_max, 1e-3)
    assert share == braking_scale(np.array([0.0, 0.5, 0.0]), hold, qdd_max, qd_max, 1e-3)


@pytest.mark.parametrize(
    ("field", "value"),
    [
        ("J", lambda J: 1e200 * J),
        ("J", lambda J: 2 * MAX_MAGNITUDE * np.sign(J + 0.1)),
        ("dw", lambda J: [1e13, 0.0]),
        ("q0", lambda J: [0.0, 0.0, -1e13]),
        ("q_min", lambda J: [-1e20, None, None]),
        ("M", lambda J: [1e13, 1.0, 1.0]),
        ("Lambda", lambda J: np.eye(3) * 1e300),
        ("f", lambda J: [0.0, 1e13, 0.0]),
        ("G", lambda J: [[1e13, 0.0, 0.0]]),
        ("k", lambda J: 1e13),
    ],
)
def test_the_python_api_refuses_numbers_beyond_the_cap(field: str, value) -> None:  # type: ignore[no-untyped-def]
    J = np.array([[1.0, 0.5, 0.25], [0.0, 1.0, 0.5]])
    fields = {"J": J, "dw": [0.01, 0.0], "q0": np.zeros(3), field: value(J)}
    if field == "G":
        fields["h"] = [1.0]
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        with pytest.raises(InvalidProblemError) as info:
            Problem(**fields)
    assert info.value.field == field
    assert "1e+12" in str(info.value)


def test_infinite_bounds_are_still_unbounded() -> None:
    P = Problem(J=[[1.0, 0.0]], dw=[0.1], q0=[0.0, 0.0], q_min=[-np.inf, None], q_max=[np.inf, 1])
    assert np.isneginf(P.q_min).all() and P.q_max[0] == np.inf


# --- lpik simulate: every option checked before the run -----------------------------------------


@pytest.fixture
def no_run(monkeypatch):  # type: ignore[no-untyped-def]
    """Make any start of a run fail the test: the options must be refused before it."""
    from lpik.paper import scenarios

    def ran(*args, **kwargs):  # type: ignore[no-untyped-def]
        raise AssertionError("the run started before the options were checked")

    monkeypatch.setattr(scenarios, "get_scenario", ran)


SIMULATE_BAD = [
    (["--steps", "3000000000"], "--steps", "MAX_STEPS"),
    (["--steps", str(simulate_cli.MAX_STEPS + 1)], "--steps", "MAX_STEPS"),
    (["--dt", "1e300"], "--dt", ""),
    (["--dt", str(2 * simulate_cli.MAX_DT)], "--dt", ""),
    (["--frames", str(simulate_cli.MAX_FRAMES + 1)], "--frames", ""),
    (["--lambda-bound", "1e300"], "--lambda-bound", ""),
    (["--out", "{tmp}/absent/run.csv"], "--out", "not found"),
    (["--out", "{tmp}/a-file/run.csv"], "--out", "not found"),
    (["--plot", "{tmp}/absent/run.png"], "--plot", "not found"),
]


@pytest.mark.parametrize(("extra", "option", "says"), SIMULATE_BAD)
def test_simulate_refuses_bad_options_before_the_run(
    tmp_path, capsys, no_run, extra, option, says
) -> None:  # type: ignore[no-untyped-def]
    (tmp_path / "a-file").write_text("x", encoding="utf-8")
    args = [a.replace("{tmp}", str(tmp_path)) for a in extra]
    code = main(["simulate", "pull-in", *args])
    line = assert_refused(code, *capsys.readouterr(), option)
    assert says in line


@pytest.mark.skipif(not Path("/proc/self").is_dir(), reason="needs Linux /proc")
def test_simulate_opens_the_output_before_the_run(capsys, no_run) -> None:  # type: ignore[no-untyped-def]
    # /proc is a directory that the permission bits call writable (for root) but
    # that holds no new files: only opening the file tells.
    code = main(["simulate", "pull-in", "--out", "/proc/lpik-run.csv"])
    assert_refused(code, *capsys.readouterr(), "--out")


def test_simulate_leaves_no_empty_file_behind_and_keeps_an_existing_one(
    tmp_path, capsys, monkeypatch
) -> None:  # type: ignore[no-untyped-def]
    from lpik.paper import scenarios

    def stop(*args, **kwargs):  # type: ignore[no-untyped-def]
        raise ValueError("scenario: stopped by the test")

    monkeypatch.setattr(scenarios, "get_scenario", stop)
    new, old = tmp_path / "new.csv", tmp_path / "old.csv"
    old.write_text("kept", encoding="utf-8")
    for path in (new, old):
        assert main(["simulate", "pull-in", "--out", str(path)]) == 2
    capsys.readouterr()
    assert not new.exists() and old.read_text(encoding="utf-8") == "kept"


def test_the_readme_quotes_the_simulate_caps() -> None:
    text = " ".join((ROOT / "README.md").read_text(encoding="utf-8").split())
    assert f"at most {simulate_cli.MAX_STEPS:,} steps (`MAX_STEPS`)" in text
    assert f"at most {simulate_cli.MAX_DT:g} s (`MAX_DT`" in text


# --- targets that are no rotation ----------------------------------------------------------------


def _panda_case():  # type: ignore[no-untyped-def]
    pytest.importorskip("numba")
    from lpik.control.controller import Lp2Controller
    from lpik.robots.registry import home_configuration, load_robot

    panda = load_robot("panda", task="pose")
    q = home_configuration("panda")
    return panda, q, Lp2Controller(panda, dt=1e-3, qdd_max=10.0)


def _with_rotation(pose: np.ndarray, rotation: np.ndarray) -> np.ndarray:
    out = pose.copy()
    out[:3, :3] = rotation
    return out


BAD_ROTATIONS = {
    "zero": (lambda T: _with_rotation(T, np.zeros((3, 3))), "det"),
    "reflection": (lambda T: _with_rotation(T, T[:3, :3] @ np.diag([1.0, 1.0, -1.0])), "det"),
    "twice-a-rotation": (lambda T: _with_rotation(T, 2.0 * T[:3, :3]), "orthonormal"),
    "sheared": (lambda T: _with_rotation(T, T[:3, :3] + 1e-3 * np.triu(np.ones((3, 3)))), "ROT"),
    "bottom-row": (lambda T: T + np.array([[0.0] * 4] * 3 + [[0.5, 0.0, 0.0, 0.0]]), "bottom"),
    "rotation-only-reflected": (lambda T: -T[:3, :3], "det"),
}


@pytest.mark.parametrize("case", list(BAD_ROTATIONS))
def test_a_target_that_is_no_rotation_is_refused_alike_everywhere(case: str) -> None:
    from lpik.command import ClampedTarget

    panda, q, controller = _panda_case()
    make, says = BAD_ROTATIONS[case]
    target = np.ascontiguousarray(make(panda.pose(q) @ _turn(0.1)))
    messages = set()
    calls = {
        "ClampedTarget": lambda t: ClampedTarget(t),
        "problem": lambda t: controller.problem(q, t),
        "step": lambda t: controller.step(q, t),
        "step list": lambda t: controller.step(q, t.tolist()),
        "step Fortran order": lambda t: controller.step(q, np.asfortranarray(t)),
        "step_into": lambda t: controller.step_into(q, t, out=np.empty(7)),
    }
    for name, call in calls.items():
        with pytest.raises(ValueError) as info:
            call(target)
        messages.add(str(info.value))
        assert str(info.value).startswith("target: "), name
    assert len(messages) == 1, messages
    assert says.replace("ROT", "ROTATION_TOL") in messages.pop()
    stack = np.stack([np.eye(target.shape[0]), target])
    with pytest.raises(ValueError, match=r"^targets: row 1: "):
        controller.step_batch(np.stack([q, q]), stack)


def _turn(angle: float) -> np.ndarray:
    c, s = np.cos(angle), np.sin(angle)
    out = np.eye(4)
    out[:2, :2] = [[c, -s], [s, c]]
    return out


def test_rotations_within_the_tolerance_step_alike_in_both_paths() -> None:
    from lpik.tolerances import ROTATION_TOL

    panda, q, controller = _panda_case()
    target = panda.pose(q) @ _turn(0.2)
    target[:3, 3] += 0.001
    rounded = target.astype(np.float32).astype(np.float64)  # what a float32 message carries
    nudged = target.copy()
    nudged[:3, :3] *= 1.0 + ROTATION_TOL / 4
    for t in (target, rounded, nudged):
        compiled = controller.step(q, t)
        numpy_path = solve(controller.problem(q, t), controller.method)
        np.testing.assert_allclose(compiled.dq, numpy_path.dq, atol=1e-12)


def test_an_orientation_target_is_checked_too() -> None:
    pytest.importorskip("numba")
    from lpik.control.controller import Lp2Controller
    from lpik.robots.registry import home_configuration, load_robot

    model = load_robot("panda", task="orientation")
    controller = Lp2Controller(model, dt=1e-3)
    q = home_configuration("panda")
    with pytest.raises(ValueError, match="^target: .*det"):
        controller.step(q, -np.eye(3))
    assert controller.step(q, model.pose(q)).status == "optimal"


def test_clamped_target_names_a_target_that_is_not_numbers() -> None:
    from lpik.command import ClampedTarget

    with pytest.raises(ValueError, match="^target: must be numbers"):
        ClampedTarget("home")
    with pytest.raises(ValueError, match="^target: contains NaN"):
        ClampedTarget([0.1, np.nan, 0.0])


# --- Lp2Controller's arguments -------------------------------------------------------------------

CONTROLLER_BAD = [
    ({"qdd_max": -1.0}, "qdd_max"),
    ({"qdd_max": 0.0}, "qdd_max"),
    ({"qdd_max": [1.0, 2.0]}, "qdd_max"),
    ({"qdd_max": np.nan}, "qdd_max"),
    ({"qdd_max": "fast"}, "qdd_max"),
    ({"dt": 0.0}, "dt"),
    ({"dt": np.nan}, "dt"),
    ({"dt": "1ms"}, "dt"),
    ({"dt": 1e-200}, "dt"),  # dt^2 was 0: the compiled step read a robot at rest as outside
    ({"v_max": -1.0}, "v_max"),
    ({"w_max": np.nan}, "w_max"),
    ({"v_max": "fast"}, "v_max"),
    ({"lambda_bound": -1.0}, "lambda_bound"),
    ({"lambda_bound": [1.0, 2.0]}, "lambda_bound"),
    ({"velocity_limits": "no"}, "velocity_limits"),
    ({"M": -np.eye(4)}, "M"),
    ({"f": [1.0]}, "f"),
    ({"Lambda": [np.nan] * 4}, "Lambda"),
    ({"q_ref": [0.0] * 3}, "q_ref"),
    ({"G": np.ones((1, 4))}, "h"),
    ({"h": [1.0]}, "G"),
    ({"G": [["a"] * 4], "h": [1.0]}, "G"),
    ({"G": np.ones((1, 3)), "h": [1.0]}, "G"),
    ({"G": np.ones((1, 4)), "h": [1.0, 2.0]}, "h"),
    ({"G": np.ones((1, 4)), "h": [1.0], "row_labels": 5}, "row_labels"),
    ({"G": np.ones((1, 4)), "h": [1.0], "row_labels": ["a", "b"]}, "row_labels"),
]


@pytest.mark.parametrize(
    ("kwargs", "name"), CONTROLLER_BAD, ids=[str(c[0])[:40] for c in CONTROLLER_BAD]
)
def test_every_controller_argument_error_names_the_argument(kwargs: dict, name: str) -> None:
    pytest.importorskip("numba")
    from lpik.control.controller import Lp2Controller
    from lpik.robots.planar import planar_arm

    arm = planar_arm([1.0] * 4, q_min=-np.pi, q_max=np.pi, qd_max=1.0)
    with pytest.raises(ValueError) as info:
        Lp2Controller(arm, **{"dt": 0.01, **kwargs})
    assert str(info.value).startswith(f"{name}: "), str(info.value)


# --- URDF files ----------------------------------------------------------------------------------


def test_load_urdf_names_a_binary_a_malformed_and_a_missing_file(tmp_path) -> None:
    from lpik.robots.urdf import load_urdf

    binary, malformed = tmp_path / "robot.urdf", tmp_path / "broken.urdf"
    binary.write_bytes(bytes(range(256)) * 4)
    malformed.write_text('<robot name="r"><link name="a"></robot', encoding="utf-8")
    cases = {binary: "UTF-8", malformed: "malformed XML", tmp_path / "absent.urdf": "No such"}
    for path, says in cases.items():
        with pytest.raises(ValueError) as info:
            load_urdf(path, tip_link="a")
        assert str(path.name) in str(info.value) and says in str(info.value)
    with pytest.raises(ValueError, match="path or XML text"):
        load_urdf(b"<robot/>", tip_link="a")  # type: ignore[arg-type]
