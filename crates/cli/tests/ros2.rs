//! `fs020n ros2` without DDS: the MoveIt files it prints, and the settings it refuses.
#![cfg(feature = "ros2")]
#![allow(clippy::expect_used)] // test code: a failed expectation is a failed test

use assert_cmd::Command;
use predicates::prelude::*;

fn fs020n() -> Command {
    Command::cargo_bin("fs020n").expect("the fs020n binary")
}

#[test]
fn prints_the_urdf_of_the_model() {
    fs020n()
        .args(["ros2", "--print", "urdf"])
        .assert()
        .success()
        .stdout(predicate::str::contains("<robot name=\"fs020n\">"))
        .stdout(predicate::str::contains(
            "<joint name=\"joint_6\" type=\"revolute\">",
        ));
}

#[test]
fn prints_moveit_controllers_for_the_action_namespace_and_joint_names() {
    let dir = tempfile::tempdir().unwrap();
    let params = dir.path().join("p.yaml");
    std::fs::write(
        &params,
        "fs020n:\n  ros__parameters:\n    joint_names: [a1, a2, a3, a4, a5, a6]\n",
    )
    .unwrap();
    fs020n()
        .args([
            "ros2",
            "--print",
            "controllers",
            "--action-namespace",
            "/arm_controller",
        ])
        .arg("--params-file")
        .arg(&params)
        .assert()
        .success()
        .stdout(predicate::str::contains(
            "  arm_controller:\n    type: FollowJointTrajectory",
        ))
        .stdout(predicate::str::contains(
            "action_ns: follow_joint_trajectory",
        ))
        .stdout(predicate::str::contains("      - a6\n"));
}

#[test]
fn prints_joint_limits_in_radians() {
    fs020n()
        .args(["ros2", "--print", "joint-limits"])
        .assert()
        .success()
        // JT1: 190 deg/s
        .stdout(predicate::str::contains("max_velocity: 3.316126"));
}

#[test]
fn bad_settings_exit_2_naming_the_setting() {
    fs020n()
        .args(["ros2", "--rate", "0", "--print", "urdf"])
        .assert()
        .code(2)
        .stderr(predicate::str::contains("joint_state_rate_hz"));
    fs020n()
        .args(["ros2", "--domain-id", "300", "--print", "urdf"])
        .assert()
        .code(2)
        .stderr(predicate::str::contains("232"));
    fs020n()
        .args(["ros2", "--service-mapping", "zenoh", "--print", "urdf"])
        .assert()
        .code(2)
        .stderr(predicate::str::contains("cyclone"));
    fs020n()
        .args(["--robot", "127.0.0.1:1", "ros2", "--embedded"])
        .assert()
        .code(2)
        .stderr(predicate::str::contains("either --robot"));
}

#[test]
fn writes_a_moveit_configuration_package_into_a_directory() {
    let dir = tempfile::tempdir().unwrap();
    let pkg = dir.path().join("fs020n_moveit_config");
    fs020n()
        .args(["ros2", "--print", "moveit-config"])
        .arg(&pkg)
        .assert()
        .success()
        .stdout(predicate::str::contains("fs020n_moveit_config"));
    for f in [
        "package.xml",
        "config/fs020n.urdf",
        "config/fs020n.srdf",
        "config/kinematics.yaml",
        "config/joint_limits.yaml",
        "config/moveit_controllers.yaml",
        "launch/move_group.launch.py",
    ] {
        assert!(pkg.join(f).is_file(), "{f} missing");
    }
    let urdf = std::fs::read_to_string(pkg.join("config/fs020n.urdf")).unwrap();
    assert!(urdf.contains("<collision>"));
    // Without a directory: refused with the remedy.
    fs020n()
        .args(["ros2", "--print", "moveit-config"])
        .assert()
        .failure()
        .stderr(predicate::str::contains("give its directory"));
}

#[test]
fn ros_args_rename_the_node_and_unknown_ones_are_refused() {
    fs020n()
        .args(["ros2", "--print", "controllers", "--ros-args", "-p"])
        .arg("action_namespace:=/arm_controller")
        .args(["-r", "__node:=arm"])
        .assert()
        .success()
        .stdout(predicate::str::contains("    - arm_controller\n"));
    fs020n()
        .args(["ros2", "--print", "urdf", "--ros-args", "--enclave", "/x"])
        .assert()
        .failure()
        .stderr(predicate::str::contains("--enclave"));
}
