//! Model-file loading: every error kind, with its file position.
#![allow(clippy::expect_used)] // test code: a failed expectation is a failed test

use fs020n_kin::{FilePosition, ModelError, RobotModel, FS020N_TOML};

/// Position of the first occurrence of `needle` in `text` (1-based line:column).
fn pos_of(text: &str, needle: &str) -> FilePosition {
    let off = text.find(needle).expect("needle present");
    FilePosition::from_offset(text, off)
}

/// Replaces the `nth` (0-based) occurrence of `from`.
fn replace_nth(text: &str, from: &str, to: &str, nth: usize) -> String {
    let (off, _) = text
        .match_indices(from)
        .nth(nth)
        .expect("occurrence present");
    format!("{}{}{}", &text[..off], to, &text[off + from.len()..])
}

#[test]
fn embedded_file_is_the_default() {
    let m = RobotModel::from_toml_str(FS020N_TOML).unwrap();
    assert_eq!(m, RobotModel::fs020n());
    assert_eq!(m.name(), "Kawasaki FS020N");
    // the file says where the speeds come from
    assert!(FS020N_TOML.contains("RS020N"));
}

#[test]
fn missing_field_names_the_key_and_position() {
    let text = FS020N_TOML.replace("accuracy_mm = 10.0\n", "");
    let e = RobotModel::from_toml_str(&text).unwrap_err();
    match &e {
        ModelError::Parse { at, message } => {
            assert!(message.contains("missing field `accuracy_mm`"), "{message}");
            let at = at.expect("position known");
            // reported at the [controller] table
            assert!(at.line >= pos_of(&text, "[controller]").line, "{at}");
        }
        other => panic!("expected Parse, got {other:?}"),
    }
    assert!(e.to_string().contains(':'));
}

#[test]
fn empty_range_reports_joint_and_position() {
    let text = FS020N_TOML.replace("min_deg = -155.0", "min_deg = 125.0");
    let e = RobotModel::from_toml_str(&text).unwrap_err();
    let expected = pos_of(&text, "125.0");
    match e {
        ModelError::EmptyRange {
            at,
            joint,
            min_deg,
            max_deg,
        } => {
            assert_eq!(joint, 3);
            assert_eq!((min_deg, max_deg), (125.0, 120.0));
            assert_eq!(at, Some(expected));
        }
        ref other => panic!("expected EmptyRange, got {other:?}"),
    }
    assert_eq!(
        e.to_string(),
        format!(
            "{}:{}: JT3: min_deg (125) must be less than max_deg (120)",
            expected.line, expected.column
        )
    );
    // min == max is also empty
    let text = FS020N_TOML.replace("min_deg = -155.0", "min_deg = 120.0");
    assert!(matches!(
        RobotModel::from_toml_str(&text),
        Err(ModelError::EmptyRange { joint: 3, .. })
    ));
}

#[test]
fn non_positive_speed_and_accel() {
    let text = FS020N_TOML.replace("max_speed_deg_s = 360.0", "max_speed_deg_s = 0.0");
    let e = RobotModel::from_toml_str(&text).unwrap_err();
    match &e {
        ModelError::NotPositive { at, key, value } => {
            assert_eq!(key, "joints[5].max_speed_deg_s");
            assert_eq!(*value, 0.0);
            let line = pos_of(&text, "max_speed_deg_s = 0.0").line;
            assert_eq!(at.map(|p| p.line), Some(line));
        }
        other => panic!("expected NotPositive, got {other:?}"),
    }
    let text = FS020N_TOML.replace("max_accel_deg_s2 = 147.0", "max_accel_deg_s2 = -1.0");
    assert!(matches!(
        RobotModel::from_toml_str(&text),
        Err(ModelError::NotPositive { ref key, .. }) if key == "joints[2].max_accel_deg_s2"
    ));
    let text = FS020N_TOML.replace("forearm_m = 0.700", "forearm_m = 0.0");
    let e = RobotModel::from_toml_str(&text).unwrap_err();
    assert!(
        e.to_string()
            .contains("geometry.forearm_m must be positive"),
        "{e}"
    );
    assert_eq!(
        e.position().map(|p| p.line),
        Some(pos_of(&text, "forearm_m = 0.0").line)
    );
}

#[test]
fn wrong_number_of_joints() {
    // drop the last [[joints]] table (JT6)
    let start = FS020N_TOML.rfind("[[joints]]").unwrap();
    let end = FS020N_TOML.find("# Geometry").unwrap();
    let text = format!("{}{}", &FS020N_TOML[..start], &FS020N_TOML[end..]);
    let e = RobotModel::from_toml_str(&text).unwrap_err();
    match e {
        ModelError::JointCount {
            at,
            found,
            expected,
        } => {
            assert_eq!((found, expected), (5, 6));
            assert!(at.is_some());
        }
        other => panic!("expected JointCount, got {other:?}"),
    }
    // a seventh joint
    let extra = "\n[[joints]]\nmin_deg = -1.0\nmax_deg = 1.0\nmax_speed_deg_s = 1.0\nmax_accel_deg_s2 = 1.0\n";
    let text = format!("{FS020N_TOML}{extra}");
    assert!(matches!(
        RobotModel::from_toml_str(&text),
        Err(ModelError::JointCount { found: 7, .. })
    ));
}

#[test]
fn syntax_errors_unknown_keys_and_types_have_positions() {
    let text = FS020N_TOML.replace("upper_arm_m = 0.800", "upper_arm_m = = 0.8");
    let e = RobotModel::from_toml_str(&text).unwrap_err();
    let line = pos_of(&text, "upper_arm_m = =").line;
    assert_eq!(e.position().map(|p| p.line), Some(line), "{e}");
    assert!(e.to_string().starts_with(&format!("{line}:")), "{e}");

    let text = FS020N_TOML.replace("flange_m = 0.0965", "flange_m = 0.0965\ntool_m = 0.1");
    let e = RobotModel::from_toml_str(&text).unwrap_err();
    assert!(e.to_string().contains("tool_m"), "{e}");
    assert_eq!(
        e.position().map(|p| p.line),
        Some(pos_of(&text, "tool_m").line)
    );

    let text = FS020N_TOML.replace("max_speed_deg_s = 190.0", "max_speed_deg_s = \"fast\"");
    let e = RobotModel::from_toml_str(&text).unwrap_err();
    assert!(matches!(e, ModelError::Parse { .. }), "{e}");
    assert_eq!(
        e.position().map(|p| p.line),
        Some(pos_of(&text, "\"fast\"").line)
    );
}

#[test]
fn home_and_controller_are_validated() {
    let text = replace_nth(FS020N_TOML, "-90.0", "-170.0", 0);
    let e = RobotModel::from_toml_str(&text).unwrap_err();
    match &e {
        ModelError::Invalid { key, at, .. } => {
            assert_eq!(key, "home_deg[3]");
            assert_eq!(*at, Some(pos_of(&text, "-170.0")));
        }
        other => panic!("expected Invalid, got {other:?}"),
    }
    assert!(e.to_string().contains("outside the JT3 range"), "{e}");

    let text = FS020N_TOML.replace(
        "home_deg = [0.0, 0.0, -90.0, 0.0, -90.0, 0.0]",
        "home_deg = [0.0]",
    );
    assert!(matches!(
        RobotModel::from_toml_str(&text),
        Err(ModelError::Invalid { ref key, .. }) if key == "home_deg"
    ));

    let text = FS020N_TOML.replace(
        "monitor_speed_percent = 10.0",
        "monitor_speed_percent = 150.0",
    );
    let e = RobotModel::from_toml_str(&text).unwrap_err();
    assert!(e.to_string().contains("(0, 100]"), "{e}");
}

#[test]
fn from_file_ok_io_error_and_positions() {
    let dir = std::env::temp_dir().join(format!("fs020n-kin-test-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let good = dir.join("good.toml");
    let mut custom = RobotModel::fs020n();
    custom.name = "my arm".into();
    custom.joints[0].max_speed_deg_s = 100.0;
    std::fs::write(&good, custom.to_toml_string()).unwrap();
    assert_eq!(RobotModel::from_file(&good).unwrap(), custom);

    let bad = dir.join("bad.toml");
    std::fs::write(
        &bad,
        FS020N_TOML.replace("min_deg = -105.0", "min_deg = 150.0"),
    )
    .unwrap();
    let e = RobotModel::from_file(&bad).unwrap_err();
    assert!(matches!(e, ModelError::InFile { .. }));
    let s = e.to_string();
    assert!(s.contains("bad.toml:") && s.contains("JT2"), "{s}");
    assert!(e.position().is_some());

    let missing = dir.join("missing.toml");
    let e = RobotModel::from_file(&missing).unwrap_err();
    assert!(matches!(e, ModelError::Io { .. }));
    assert!(e.position().is_none());
    std::fs::remove_dir_all(&dir).unwrap();
}

#[test]
fn serde_deserialize_validates() {
    let text = FS020N_TOML.replace("min_deg = -155.0", "min_deg = 125.0");
    let r: Result<RobotModel, _> = toml::from_str(&text);
    assert!(r.is_err());
    let ok: RobotModel = toml::from_str(FS020N_TOML).unwrap();
    assert_eq!(ok, RobotModel::fs020n());
}

#[test]
fn validate_catches_hand_edits() {
    let mut m = RobotModel::fs020n();
    assert!(m.validate().is_ok());
    m.joints[4].max_accel_deg_s2 = f64::NAN;
    assert!(m.validate().is_err());
}
