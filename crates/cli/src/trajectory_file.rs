//! Trajectory files for `play`: CSV (`time_s,j1..j6` or `time_s,j1..j6,v1..v6,a1..a6`, with or
//! without a header) or JSON (`[{"time_s":0,"position_deg":[..6],"velocity_deg_s":[..6]?,
//! "acceleration_deg_s2":[..6]?}, …]`, or the same array under `"points"`).
//!
//! The whole file is validated before anything moves; errors name the line and column.

use std::path::Path;

use fs020n_kin::RobotModel;
use fs020n_proto::JointsDeg;
use serde::Deserialize;

use crate::error::{CliError, CliResult};

/// One point of a trajectory file.
#[derive(Debug, Clone, PartialEq)]
pub(crate) struct FilePoint {
    /// Time from the start, seconds.
    pub time_s: f64,
    /// Joint positions, degrees.
    pub position: JointsDeg,
    /// Joint velocities, deg/s.
    pub velocity: Option<JointsDeg>,
    /// Joint accelerations, deg/s².
    pub acceleration: Option<JointsDeg>,
    /// Where it came from, for messages ("line 3").
    pub origin: String,
}

/// Reads and validates a trajectory file.
pub(crate) fn load(path: &Path, model: &RobotModel) -> CliResult<Vec<FilePoint>> {
    let text = std::fs::read_to_string(path)
        .map_err(|e| CliError::input(format!("cannot read {}: {e}", path.display())))?;
    let is_json = path
        .extension()
        .is_some_and(|e| e.eq_ignore_ascii_case("json"))
        || text.trim_start().starts_with(['[', '{']);
    let points = if is_json {
        parse_json(&text)
    } else {
        parse_csv(&text)
    }
    .map_err(|e| CliError::input(format!("{}: {e}", path.display())))?;
    validate(&points, model).map_err(|e| CliError::input(format!("{}: {e}", path.display())))?;
    Ok(points)
}

const NAMES: [&str; 19] = [
    "time_s", "j1", "j2", "j3", "j4", "j5", "j6", "v1", "v2", "v3", "v4", "v5", "v6", "a1", "a2",
    "a3", "a4", "a5", "a6",
];

/// Parses CSV text.
pub(crate) fn parse_csv(text: &str) -> Result<Vec<FilePoint>, String> {
    let mut reader = csv::ReaderBuilder::new()
        .has_headers(false)
        .trim(csv::Trim::All)
        .comment(Some(b'#'))
        .flexible(true)
        .from_reader(text.as_bytes());
    let mut points = Vec::new();
    let mut width: Option<usize> = None;
    for (k, record) in reader.records().enumerate() {
        let record = record.map_err(|e| format!("malformed CSV: {e}"))?;
        let line = record.position().map_or(k as u64 + 1, |p| p.line());
        if record.iter().all(|f| f.is_empty()) {
            continue;
        }
        // A first row that does not start with a number is a header.
        if points.is_empty()
            && width.is_none()
            && record.get(0).is_some_and(|f| f.parse::<f64>().is_err())
        {
            if record.len() != 7 && record.len() != 19 {
                return Err(format!(
                    "line {line}: the header has {} columns; expected 7 (time_s,j1..j6) or 19 (time_s,j1..j6,v1..v6,a1..a6)",
                    record.len()
                ));
            }
            width = Some(record.len());
            continue;
        }
        let n = record.len();
        if n != 7 && n != 19 {
            return Err(format!(
                "line {line}: {n} columns; expected 7 (time_s,j1..j6) or 19 (time_s,j1..j6,v1..v6,a1..a6)"
            ));
        }
        if let Some(w) = width {
            if w != n {
                return Err(format!(
                    "line {line}: {n} columns, but earlier rows have {w}"
                ));
            }
        }
        width = Some(n);
        let mut v = [0.0; 19];
        for (c, field) in record.iter().enumerate() {
            v[c] = field
                .parse::<f64>()
                .ok()
                .filter(|x| x.is_finite())
                .ok_or_else(|| {
                    format!(
                        "line {line}, column {} ({}): {field:?} is not a finite number",
                        c + 1,
                        NAMES[c]
                    )
                })?;
        }
        let j = |from: usize| {
            JointsDeg::new([
                v[from],
                v[from + 1],
                v[from + 2],
                v[from + 3],
                v[from + 4],
                v[from + 5],
            ])
        };
        points.push(FilePoint {
            time_s: v[0],
            position: j(1),
            velocity: (n == 19).then(|| j(7)),
            acceleration: (n == 19).then(|| j(13)),
            origin: format!("line {line}"),
        });
    }
    Ok(points)
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct JsonPoint {
    time_s: f64,
    #[serde(alias = "joints_deg")]
    position_deg: [f64; 6],
    #[serde(default)]
    velocity_deg_s: Option<[f64; 6]>,
    #[serde(default)]
    acceleration_deg_s2: Option<[f64; 6]>,
}

/// What a JSON trajectory file must look like (for messages).
const JSON_SHAPE: &str = "an array of points (or {\"points\": [...]}), each \
    {\"time_s\": number, \"position_deg\": [6 numbers], optional \"velocity_deg_s\": [6 numbers], \
    optional \"acceleration_deg_s2\": [6 numbers]}";

/// Parses JSON text.
pub(crate) fn parse_json(text: &str) -> Result<Vec<FilePoint>, String> {
    // First a syntax check, which reports line and column.
    let value: serde_json::Value = serde_json::from_str(text).map_err(|e| {
        format!(
            "invalid JSON at line {}, column {}: {e}",
            e.line(),
            e.column()
        )
    })?;
    let items = match value {
        serde_json::Value::Array(items) => items,
        serde_json::Value::Object(mut map) => match map.remove("points") {
            Some(serde_json::Value::Array(items)) if map.is_empty() => items,
            _ => return Err(format!("expected {JSON_SHAPE}")),
        },
        _ => return Err(format!("expected {JSON_SHAPE}")),
    };
    items
        .into_iter()
        .enumerate()
        .map(|(i, item)| {
            let p: JsonPoint = serde_json::from_value(item)
                .map_err(|e| format!("point {}: {e}; expected {JSON_SHAPE}", i + 1))?;
            Ok(FilePoint {
                time_s: p.time_s,
                position: JointsDeg::new(p.position_deg),
                velocity: p.velocity_deg_s.map(JointsDeg::new),
                acceleration: p.acceleration_deg_s2.map(JointsDeg::new),
                origin: format!("point {}", i + 1),
            })
        })
        .collect()
}

/// Checks times, finiteness, ranges and speeds between points.
pub(crate) fn validate(points: &[FilePoint], model: &RobotModel) -> Result<(), String> {
    if points.is_empty() {
        return Err("no points".to_owned());
    }
    let speeds = model.max_speeds_deg_s();
    for (i, p) in points.iter().enumerate() {
        if !p.time_s.is_finite() || p.time_s < 0.0 {
            return Err(format!(
                "{}: time_s {} must be a finite number ≥ 0",
                p.origin, p.time_s
            ));
        }
        for (what, j) in [
            ("position", Some(p.position)),
            ("velocity", p.velocity),
            ("acceleration", p.acceleration),
        ] {
            if let Some(j) = j {
                if !j.is_finite() {
                    return Err(format!("{}: {what} is not finite", p.origin));
                }
            }
        }
        model
            .check_limits(&p.position)
            .map_err(|e| format!("{}: {e}", p.origin))?;
        if i > 0 {
            let prev = &points[i - 1];
            let dt = p.time_s - prev.time_s;
            if dt <= 0.0 {
                return Err(format!(
                    "{}: time_s {} does not increase (previous point at {})",
                    p.origin, p.time_s, prev.time_s
                ));
            }
            for j in 0..6 {
                let v = (p.position[j] - prev.position[j]).abs() / dt;
                if v > speeds[j] {
                    return Err(format!(
                        "{}: JT{} would move at {v:.1} deg/s from the previous point, above its maximum {} deg/s",
                        p.origin,
                        j + 1,
                        speeds[j]
                    ));
                }
            }
        }
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn csv_with_header_and_derivatives() {
        let text = "time_s,j1,j2,j3,j4,j5,j6\n0,0,0,-90,0,-90,0\n0.5,1,0,-90,0,-90,0\n";
        let p = parse_csv(text).unwrap();
        assert_eq!(p.len(), 2);
        assert_eq!(p[1].position[0], 1.0);
        assert!(p[1].velocity.is_none());
        validate(&p, &RobotModel::fs020n()).unwrap();
        let mut row = String::from("0");
        for _ in 0..18 {
            row.push_str(",1");
        }
        let p = parse_csv(&row).unwrap();
        assert_eq!(p[0].velocity.unwrap()[5], 1.0);
    }

    #[test]
    fn csv_errors_name_line_and_column() {
        let e = parse_csv("0,0,0,-90,0,-90,0\n1,0,0,x,0,-90,0\n").unwrap_err();
        assert!(e.contains("line 2, column 4 (j3)"), "{e}");
        let e = parse_csv("0,0,0\n").unwrap_err();
        assert!(e.contains("line 1: 3 columns"), "{e}");
        let p = parse_csv("0,0,0,-90,0,-90,0\n1,0,0,130,0,-90,0\n").unwrap();
        let e = validate(&p, &RobotModel::fs020n()).unwrap_err();
        assert!(e.contains("line 2") && e.contains("JT3"), "{e}");
        let p = parse_csv("0,0,0,-90,0,-90,0\n0,0,0,-90,0,-90,0\n").unwrap();
        assert!(validate(&p, &RobotModel::fs020n())
            .unwrap_err()
            .contains("does not increase"));
    }

    #[test]
    fn the_shipped_example_is_valid() {
        let path =
            std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../../examples/circle.csv");
        let p = load(&path, &RobotModel::fs020n()).unwrap();
        assert_eq!(p.len(), 301);
        assert_eq!(p[0].position, RobotModel::fs020n().home);
    }

    #[test]
    fn json_forms() {
        let p = parse_json(r#"[{"time_s":0,"position_deg":[0,0,-90,0,-90,0]}]"#).unwrap();
        assert_eq!(p[0].position[2], -90.0);
        let p = parse_json(r#"{"points":[{"time_s":0,"joints_deg":[0,0,-90,0,-90,0],"velocity_deg_s":[1,0,0,0,0,0]}]}"#).unwrap();
        assert_eq!(p[0].velocity.unwrap()[0], 1.0);
        let e = parse_json("[{\"time_s\":0,\n\"position_deg\":[0,0]]").unwrap_err();
        assert!(e.contains("line 2"), "{e}");
        // Structure errors name the point and the field, never the parser's own types.
        let e = parse_json(r#"[{"time_s":0,"position_deg":[0,0,-90,0,-90,0]},{"time_s":1}]"#)
            .unwrap_err();
        assert!(
            e.starts_with("point 2: missing field `position_deg`"),
            "{e}"
        );
        assert!(!e.contains("untagged") && !e.contains("JsonFile"), "{e}");
        let e = parse_json(r#"{"pts": []}"#).unwrap_err();
        assert!(e.starts_with("expected an array of points"), "{e}");
        let e = parse_json(r#"[{"time_s":0,"position_deg":[0,0,-90,0,-90]}]"#).unwrap_err();
        assert!(e.contains("point 1") && e.contains("6"), "{e}");
    }
}
