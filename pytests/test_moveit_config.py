"""The MoveIt configuration package written by `fs020n ros2 --print moveit-config DIR`, read by
independent libraries from PyPI: the URDF by yourdfpy (loading, collision geometry, forward
kinematics compared with `fs020n fk`), the SRDF by the standard library's XML parser (every link
and joint it names exists in the URDF), the YAML files by PyYAML.

Needs the fs020n binary built with --features ros2 in FS020N_BIN (scripts/test-all sets it).
"""

import json
import math
import os
import random
import subprocess
import xml.etree.ElementTree as ET

import numpy as np
import pytest
import yaml
import yourdfpy

JOINTS = [f"joint_{i}" for i in range(1, 7)]


def binary():
    b = os.environ.get("FS020N_BIN")
    assert b, "FS020N_BIN must name the fs020n binary built with --features ros2 (scripts/test-all)"
    return b


@pytest.fixture(scope="module")
def package(tmp_path_factory):
    d = tmp_path_factory.mktemp("moveit") / "fs020n_moveit_config"
    out = subprocess.run([binary(), "--json", "ros2", "--print", "moveit-config", str(d)],
                         capture_output=True, text=True, timeout=120, check=True)
    line = json.loads(out.stdout)
    assert line["package"] == str(d)
    return d


@pytest.fixture(scope="module")
def urdf(package):
    return yourdfpy.URDF.load(str(package / "config" / "fs020n.urdf"), load_meshes=False,
                              build_collision_scene_graph=False)


def test_the_urdf_loads_with_six_revolute_joints_and_validates(urdf):
    assert urdf.validate(), "yourdfpy reports the URDF invalid"
    assert urdf.actuated_joint_names == JOINTS
    assert urdf.base_link == "base_link"
    for name in JOINTS:
        j = urdf.joint_map[name]
        assert j.type == "revolute" and j.limit.upper > j.limit.lower


def test_every_link_but_the_tool_frame_has_collision_geometry(urdf):
    names = set(urdf.link_map)
    assert names == {"base_link", "link_1", "link_2", "link_3", "link_4", "link_5", "link_6",
                     "flange", "tool0"}
    for name, link in urdf.link_map.items():
        if name == "tool0":  # the ROS-Industrial tool frame: a frame without a body
            assert not link.collisions
            continue
        assert link.collisions, f"{name} has no collision geometry"
        for c in link.collisions:
            g = c.geometry
            prim = g.cylinder or g.sphere or g.box
            assert prim is not None, f"{name}: collision without a primitive"
            assert (g.cylinder or g.sphere).radius > 0.0


def fk_binary(deg):
    out = subprocess.run([binary(), "--json", "fk", *[str(d) for d in deg]],
                         capture_output=True, text=True, timeout=60, check=True)
    return json.loads(out.stdout.strip().splitlines()[-1])


def rot_z(a):
    c, s = math.cos(a), math.sin(a)
    return np.array([[c, -s, 0], [s, c, 0], [0, 0, 1]])


def rot_y(a):
    c, s = math.cos(a), math.sin(a)
    return np.array([[c, 0, s], [0, 1, 0], [-s, 0, c]])


def test_forward_kinematics_agrees_with_fs020n_fk(urdf):
    rng = random.Random(24)
    configs = [[0, 0, -90, 0, -90, 0], [0] * 6, [30, 20, -60, 10, -45, 90]]
    for _ in range(12):
        configs.append([rng.uniform(j.limit.lower, j.limit.upper) * 180 / math.pi * 0.95
                        for j in (urdf.joint_map[n] for n in JOINTS)])
    for deg in configs:
        urdf.update_cfg(np.radians(deg))
        t = urdf.get_transform("flange", "base_link")
        p = fk_binary(deg)
        pos_mm = t[:3, 3] * 1000.0
        assert np.allclose(pos_mm, [p["x_mm"], p["y_mm"], p["z_mm"]], atol=0.01), (deg, pos_mm, p)
        # O, A, T are Z-Y-Z Euler angles: R = Rz(O) Ry(A) Rz(T).
        r = rot_z(math.radians(p["o_deg"])) @ rot_y(math.radians(p["a_deg"])) @ rot_z(math.radians(p["t_deg"]))
        assert np.allclose(t[:3, :3], r, atol=1e-4), (deg, t[:3, :3], r)
        # tool0 coincides with the flange.
        assert np.allclose(urdf.get_transform("tool0", "base_link"), t, atol=1e-12)


def test_the_srdf_names_existing_links_and_joints(package, urdf):
    root = ET.parse(package / "config" / "fs020n.srdf").getroot()
    assert root.tag == "robot" and root.get("name") == urdf.robot.name
    links, joints = set(urdf.link_map), set(urdf.joint_map)
    group = root.find("group[@name='manipulator']")
    chain = group.find("chain")
    assert chain.get("base_link") in links and chain.get("tip_link") in links
    states = {s.get("name"): s for s in root.findall("group_state")}
    assert set(states) == {"home", "zero"}
    for state in states.values():
        assert state.get("group") == "manipulator"
        values = {j.get("name"): float(j.get("value")) for j in state.findall("joint")}
        assert set(values) == set(JOINTS) and set(values) <= joints
        for name, v in values.items():
            lim = urdf.joint_map[name].limit
            assert lim.lower <= v <= lim.upper
    assert states["home"].find("joint[@name='joint_3']").get("value").startswith("-1.5707")
    pairs = root.findall("disable_collisions")
    assert pairs
    reasons = set()
    for p in pairs:
        assert p.get("link1") in links and p.get("link2") in links
        reasons.add(p.get("reason"))
    assert reasons <= {"Adjacent", "Never", "Always"}
    # Every parent-child pair of bodies is Adjacent.
    adjacent = {(p.get("link1"), p.get("link2")) for p in pairs if p.get("reason") == "Adjacent"}
    for j in urdf.robot.joints:
        if j.child != "tool0":
            assert (j.parent, j.child) in adjacent, (j.parent, j.child)
    assert "10000 configurations" in (package / "config" / "fs020n.srdf").read_text()


def test_the_yaml_files_parse_and_carry_the_models_limits(package, urdf):
    cfg = package / "config"
    limits = yaml.safe_load((cfg / "joint_limits.yaml").read_text())["joint_limits"]
    for name in JOINTS:
        assert limits[name]["has_acceleration_limits"] is True
        assert limits[name]["max_velocity"] == pytest.approx(urdf.joint_map[name].limit.velocity, abs=1e-5)
    assert limits["joint_1"]["max_acceleration"] == pytest.approx(math.radians(235.0), abs=1e-5)
    kin = yaml.safe_load((cfg / "kinematics.yaml").read_text())
    assert kin["manipulator"]["kinematics_solver"] == "kdl_kinematics_plugin/KDLKinematicsPlugin"
    ctl = yaml.safe_load((cfg / "moveit_controllers.yaml").read_text())
    mscm = ctl["moveit_simple_controller_manager"]
    assert mscm["controller_names"] == ["fs020n_controller"]
    assert mscm["fs020n_controller"]["type"] == "FollowJointTrajectory"
    assert mscm["fs020n_controller"]["action_ns"] == "follow_joint_trajectory"
    assert mscm["fs020n_controller"]["joints"] == JOINTS
    sa = yaml.safe_load((package / ".setup_assistant").read_text())["moveit_setup_assistant_config"]
    assert (package / sa["urdf"]["relative_path"]).is_file()
    assert (package / sa["srdf"]["relative_path"]).is_file()
    manifest = ET.parse(package / "package.xml").getroot()
    assert manifest.find("name").text == "fs020n_moveit_config"
    for launch in ("move_group.launch.py", "fs020n.launch.py"):
        compile((package / "launch" / launch).read_text(), launch, "exec")
