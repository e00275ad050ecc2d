"""Collision capsules of the bundled UR5e and iiwa14, from MuJoCo Menagerie's collision geoms.

Neither bundled URDF has ``<collision>`` primitives (only meshes upstream), so
the capsules come from the collision geoms that MuJoCo Menagerie
(``google-deepmind/mujoco_menagerie``) gives the same arms:

* ``universal_robots_ur5e/ur5e.xml`` (BSD-3-Clause, ROS-Industrial): capsules
  (and one cylinder, on ``wrist_3_link``, taken as the capsule on its axis),
  used as they are: two on the upper arm and the forearm (the joint's housing
  and the tube, which runs 0.138 m (upper arm) and 0.007 m (forearm) from
  the joints' origins along their axes: a segment between joint origins
  would miss the upper arm by 0.138 m), one on each other link; the model
  has none on its base.
* ``kuka_iiwa_14/iiwa14.xml`` (BSD-3-Clause, from Drake): 46 spheres; each
  link's spheres, split in two groups along their principal axis where that
  makes the capsule much tighter, are enclosed by the capsule on that axis
  through the outermost centres whose radius covers every sphere (rounded up
  to the millimetre, plus one millimetre for the ends' rounding).

Each geom was placed in lpik's joint frames (:meth:`~lpik.robots.chain.SerialChain.joint_frames`)
by the constant transform between a Menagerie body and lpik's frame of the
same joint: the two chains agree once Menagerie's world is turned by -90 deg
(UR5e) or 0 deg (iiwa14) about z, with the same joint signs and zeros; that
transform stays the same to 1.7 mm (UR5e) and 0.9 mm (iiwa14) over random
configurations (the descriptions' own small differences, e.g. 0.163 vs
0.1625 m at the UR5e's shoulder). Ends are given to 0.1 mm, sub-millimetre
offsets across a joint's axis dropped. Entries: ``(joint, a, b, radius)``
with ``joint`` -1 for the base [m].
"""

from __future__ import annotations

#: Capsules per bundled arm (sources in the module's docstring).
BUNDLED_CAPSULES: dict[str, tuple[tuple[int, tuple[float, ...], tuple[float, ...], float], ...]] = {
    "ur5e": (
        (0, (0.0, 0.0, -0.0995), (0.0, 0.0, 0.0205), 0.06),
        (1, (0.0, 0.0, 0.158), (0.0, 0.0, 0.038), 0.06),
        (1, (0.0, 0.0, 0.138), (-0.4, 0.0, 0.138), 0.05),
        (2, (0.0, 0.0, 0.147), (0.0, 0.0, 0.027), 0.055),
        (2, (-0.01, 0.0, 0.007), (-0.39, 0.0, 0.007), 0.038),
        (3, (0.0, 0.0, -0.0063), (0.0, 0.0, -0.1463), 0.04),
        (4, (0.0, 0.0, -0.1202), (0.0, 0.0, -0.0002), 0.04),
        (4, (0.0, 0.0607, -0.0002), (0.0, -0.0193, -0.0002), 0.04),
        (5, (0.0, 0.0, 0.0011), (0.0, 0.0, -0.0389), 0.04),
    ),
    "iiwa14": (
        (-1, (0.0, 0.0, 0.14), (-0.08, 0.0, 0.103), 0.102),
        (-1, (0.0, 0.0, 0.03), (-0.08, 0.0, 0.04), 0.122),
        (0, (0.0, -0.0463, 0.2595), (0.0, -0.0032, 0.1557), 0.087),
        (1, (0.0, 0.0012, 0.1805), (0.0, 0.0557, 0.0407), 0.082),
        (1, (0.0, -0.01, 0.0), (0.0, 0.045, 0.0), 0.096),
        (2, (0.0, 0.0601, 0.3783), (0.0, 0.0031, 0.2387), 0.08),
        (2, (0.0, 0.0, 0.42), (0.0, 0.045, 0.42), 0.077),
        (3, (0.0, -0.034, 0.12), (0.0, 0.0, 0.184), 0.077),
        (3, (0.0, -0.052, 0.06), (0.0, -0.046, 0.01), 0.08),
        (4, (0.0, -0.0114, 0.2135), (0.0, -0.0723, 0.3671), 0.089),
        (5, (0.0, 0.011, -0.03), (0.0, 0.011, -0.03), 0.066),
        (5, (0.0, 0.0, 0.0), (0.0, -0.059, 0.0), 0.081),
        (6, (0.0, 0.0, 0.082), (0.0, 0.0, 0.082), 0.061),
    ),
}
