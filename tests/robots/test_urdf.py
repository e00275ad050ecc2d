"""URDF loading: the chain between two links, and clear errors for bad files."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from robot_cases import MIXED_URDF, joint, robot

from lpik.robots.urdf import load_urdf, parse_urdf

TWO = ["a", "b", "c"]


def two_joints(second: str) -> str:
    return robot(TWO, [joint("j1", "a", "b"), second])


def test_loads_from_a_file_and_from_text(tmp_path: Path) -> None:
    path = tmp_path / "mixed.urdf"
    path.write_text(MIXED_URDF)
    from_file = load_urdf(path, "tool")
    from_text = load_urdf(MIXED_URDF, "tool")
    q = np.array([0.1, 0.2, 0.3, 0.4])
    assert np.array_equal(from_file.fk(q), from_text.fk(q))
    assert from_file.name == "mixed" and from_file.base_link == "base"


def test_base_link_other_than_the_root() -> None:
    full = load_urdf(MIXED_URDF, "tool")
    sub = load_urdf(MIXED_URDF, "tool", base_link="l2")
    assert sub.joint_names == ("pri", "cont", "rev2")
    q = np.array([0.3, 0.1, -0.2, 0.5])
    relative = np.linalg.inv(full.fk(q, "l2")) @ full.fk(q)
    assert np.allclose(sub.fk(q[1:]), relative)


def test_unknown_tags_are_ignored_quietly(capsys: pytest.CaptureFixture[str]) -> None:
    text = MIXED_URDF.replace("</robot>", "<gazebo/><mujoco><compiler/></mujoco></robot>")
    load_urdf(text, "tool")
    assert capsys.readouterr().err == ""


@pytest.mark.parametrize(
    ("text", "tip", "base", "message"),
    [
        ('<robot name="r"><link name="a"/>', "a", None, "malformed XML"),
        ('<robox name="r"><link name="a"/></robox>', "a", None, "root element is <robox>"),
        ('<robot><link name="a"/></robot>', "a", None, r"/robot.*name"),
        (two_joints(joint("j2", "b", "c")), "nope", None, "unknown tip link 'nope'; available: a"),
        (two_joints(joint("j2", "b", "c")), "c", "zzz", "unknown base link 'zzz'"),
        (
            robot(TWO, [joint("j1", "a", "b"), joint("j2", "a", "c")]),
            "c",
            "b",
            "'b' and 'c' do not form a chain",
        ),
        (two_joints(joint("j2", "b", "c", "floating", limit=None)), "c", None, "j2.*floating"),
        (two_joints(joint("j2", "b", "c", "planar", limit=None)), "c", None, "j2.*planar"),
        (two_joints(joint("j2", "b", "c", "ball", limit=None)), "c", None, "j2.*ball"),
        (two_joints(joint("j2", "b", "c", limit=None)), "c", None, "joint 'j2' has no <limit>"),
        (
            two_joints(joint("j2", "b", "c", "prismatic", limit=None)),
            "c",
            None,
            "prismatic joint 'j2' has no <limit>",
        ),
        (
            two_joints(joint("j2", "b", "c", limit='lower="0" upper="1" effort="1"')),
            "c",
            None,
            r"joint\[@name='j2'\]/limit.*velocity",
        ),
        (
            two_joints(joint("j2", "b", "c", limit='lower="1" upper="0" velocity="1" effort="1"')),
            "c",
            None,
            "joint 'j2' <limit>: need finite lower <= upper",
        ),
        (
            two_joints(joint("j2", "b", "c", limit='lower="0" upper="1" velocity="0" effort="1"')),
            "c",
            None,
            "joint 'j2' <limit>: velocity must be > 0",
        ),
        (two_joints(joint("j2", "b", "c", xyz="0 x 0")), "c", None, r"joint\[@name='j2'\]/origin"),
        (two_joints(joint("j2", "b", "c", axis="0 0 0")), "c", None, "joint 'j2' <axis>"),
        (two_joints(joint("j2", "b", "zz")), "c", None, "joint 'j2' names child link 'zz'"),
        (two_joints(joint("j2", "a", "b")), "b", None, "link 'b' is the child of two joints"),
        (
            robot(["a", "a", "b"], [joint("j1", "a", "b")]),
            "b",
            None,
            "duplicate link name 'a'",
        ),
        (
            two_joints(joint("j2", "b", "c", extra='<mimic joint="j1"/>')),
            "c",
            None,
            "joint 'j2' on the chain mimics 'j1'",
        ),
        (robot(TWO, [joint("j1", "a", "b")]), "b", None, "expected one root link, found 2"),
        (
            robot(
                TWO, [joint("j1", "a", "b", "fixed", limit=None), joint("j2", "b", "c", "fixed")]
            ),
            "c",
            None,
            "has no moving joint",
        ),
    ],
)
def test_bad_files_name_the_element(text: str, tip: str, base: str | None, message: str) -> None:
    with pytest.raises(ValueError, match=message):
        load_urdf(text, tip, base_link=base)


def test_missing_file_is_a_value_error(tmp_path: Path) -> None:
    with pytest.raises(ValueError, match="nothing.urdf' cannot be read"):
        load_urdf(tmp_path / "nothing.urdf", "tip")


def test_off_chain_joints_of_any_type_are_ignored() -> None:
    text = robot(
        ["a", "b", "c", "d"],
        [
            joint("j1", "a", "b"),
            joint("free", "a", "c", "floating", limit=None),
            joint("mim", "b", "d", limit=None, extra='<mimic joint="j1"/>'),
        ],
    )
    chain = load_urdf(text, "b")
    assert chain.joint_names == ("j1",)


def test_continuous_joint_velocity_limit_is_used_when_given() -> None:
    text = two_joints(joint("j2", "b", "c", "continuous", limit='velocity="3" effort="1"'))
    chain = load_urdf(text, "c")
    assert chain.qd_max[1] == 3.0 and np.isinf(chain.q_max[1])


def test_parse_urdf_exposes_the_tree() -> None:
    robot_model = parse_urdf(MIXED_URDF)
    assert robot_model.parent_map["tool"] == ("fix2", "flange")
