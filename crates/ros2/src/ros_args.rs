//! ROS 2's own command-line arguments, as `launch_ros`'s `Node()` passes them after
//! `--ros-args`: `-r/--remap FROM:=TO` (with `__node` and `__ns`), `-p/--param NAME:=VALUE`,
//! `--params-file FILE`, `--log-level LEVEL` (accepted, logging follows `-v`), and `--`/a
//! further `--ros-args`. Anything else is refused with its name. Names follow ROS 2's rules:
//! `~/x` is under the node, `x` under its namespace, `/x` absolute; a remap applies when both
//! sides name the same topic or service once expanded.

use std::path::PathBuf;

use crate::config::NodeConfig;
use crate::error::Ros2Error;

/// The parsed arguments.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct RosArgs {
    /// `__node:=NAME`.
    pub node_name: Option<String>,
    /// `__ns:=NS`.
    pub namespace: Option<String>,
    /// Other remaps, in order: (from, to).
    pub remaps: Vec<(String, String)>,
    /// `-p` parameters, in order: (name, YAML value).
    pub params: Vec<(String, String)>,
    /// `--params-file` files, in order.
    pub params_files: Vec<PathBuf>,
}

fn bad(m: String) -> Ros2Error {
    Ros2Error::Config(m)
}

fn split_assignment<'a>(what: &str, text: &'a str) -> Result<(&'a str, &'a str), Ros2Error> {
    match text.split_once(":=") {
        Some((a, b)) if !a.is_empty() && !b.is_empty() => Ok((a, b)),
        _ => Err(bad(format!(
            "--ros-args {what} {text:?}: expected FROM:=TO (e.g. joint_states:=arm/joint_states)"
        ))),
    }
}

impl RosArgs {
    /// Parses the arguments after `--ros-args`.
    ///
    /// ```
    /// let args: Vec<String> = ["-r", "__node:=arm", "-r", "joint_states:=js", "-p", "feedback_rate_hz:=10.0"]
    ///     .map(String::from).to_vec();
    /// let a = fs020n_ros2::RosArgs::parse(&args).unwrap();
    /// assert_eq!(a.node_name.as_deref(), Some("arm"));
    /// assert_eq!(a.remaps, [("joint_states".to_owned(), "js".to_owned())]);
    /// ```
    pub fn parse(args: &[String]) -> Result<RosArgs, Ros2Error> {
        let mut out = RosArgs::default();
        let mut it = args.iter();
        while let Some(flag) = it.next() {
            let mut value = |what: &str| {
                it.next()
                    .cloned()
                    .ok_or_else(|| bad(format!("--ros-args {what} needs a value")))
            };
            match flag.as_str() {
                "--ros-args" | "--" => {}
                "-r" | "--remap" => {
                    let v = value(flag)?;
                    let (from, to) = split_assignment(flag, &v)?;
                    match from {
                        "__node" | "__name" => out.node_name = Some(to.to_owned()),
                        "__ns" => out.namespace = Some(to.to_owned()),
                        _ => out.remaps.push((from.to_owned(), to.to_owned())),
                    }
                }
                "-p" | "--param" => {
                    let v = value(flag)?;
                    let (name, val) = split_assignment(flag, &v)?;
                    out.params.push((name.to_owned(), val.to_owned()));
                }
                "--params-file" => out.params_files.push(PathBuf::from(value(flag)?)),
                "--log-level" => {
                    value(flag)?;
                }
                other => {
                    return Err(bad(format!(
                        "--ros-args {other:?} is not supported; the node accepts -r/--remap, \
                         -p/--param, --params-file and --log-level"
                    )))
                }
            }
        }
        Ok(out)
    }
}

impl NodeConfig {
    /// Applies ROS 2 arguments: the node name and namespace, then the parameter files, then
    /// the `-p` parameters; the remaps are kept for [`NodeConfig::resolve`]. Call
    /// [`validate`](Self::validate) after.
    pub fn apply_ros_args(&mut self, args: &RosArgs) -> Result<(), Ros2Error> {
        if let Some(n) = &args.node_name {
            self.node_name = n.clone();
        }
        if let Some(ns) = &args.namespace {
            self.namespace = if ns.starts_with('/') {
                ns.clone()
            } else {
                format!("/{ns}")
            };
        }
        for f in &args.params_files {
            self.apply_params_file(f)?;
        }
        for (name, value) in &args.params {
            let yaml = format!("/**:\n  ros__parameters:\n    {name}: {value}\n");
            self.apply_params_yaml(&yaml)
                .map_err(|e| bad(format!("--ros-args -p {name}:={value}: {e}")))?;
        }
        self.remaps.extend(args.remaps.iter().cloned());
        Ok(())
    }

    /// `name` expanded by ROS 2's rules (`~` the node, relative names under the namespace).
    pub fn expand(&self, name: &str) -> String {
        let fqn = self.fully_qualified_name();
        if name == "~" {
            fqn
        } else if let Some(rest) = name.strip_prefix("~/") {
            format!("{fqn}/{rest}")
        } else if name.starts_with('/') {
            name.to_owned()
        } else if self.namespace == "/" {
            format!("/{name}")
        } else {
            format!("{}/{name}", self.namespace)
        }
    }

    /// The fully qualified name of topic or service `name` after the remaps: the first remap
    /// whose `from` expands to the same name gives its `to`, expanded.
    ///
    /// ```
    /// let mut c = fs020n_ros2::NodeConfig::default();
    /// c.namespace = "/cell".into();
    /// c.remaps.push(("joint_states".into(), "/robot/joint_states".into()));
    /// assert_eq!(c.resolve("joint_states"), "/robot/joint_states");
    /// assert_eq!(c.resolve("~/start"), "/cell/fs020n/start");
    /// ```
    pub fn resolve(&self, name: &str) -> String {
        let full = self.expand(name);
        self.remaps
            .iter()
            .find(|(from, _)| self.expand(from) == full)
            .map_or(full, |(_, to)| self.expand(to))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn args(a: &[&str]) -> Vec<String> {
        a.iter().map(|s| s.to_string()).collect()
    }

    #[test]
    fn launch_ros_arguments_set_name_namespace_parameters_and_remaps() {
        let a = RosArgs::parse(&args(&[
            "--ros-args",
            "-r",
            "__node:=robot",
            "-r",
            "__ns:=/cell",
            "-p",
            "feedback_rate_hz:=10.0",
            "-p",
            "joint_names:=[a1, a2, a3, a4, a5, a6]",
            "--remap",
            "joint_states:=js",
            "--log-level",
            "info",
        ]))
        .unwrap();
        let mut c = NodeConfig::default();
        c.apply_ros_args(&a).unwrap();
        c.validate().unwrap();
        assert_eq!(c.fully_qualified_name(), "/cell/robot");
        assert_eq!(c.feedback_rate_hz, 10.0);
        assert_eq!(c.joint_names[5], "a6");
        assert_eq!(c.resolve("joint_states"), "/cell/js");
        // An absolute name elsewhere is another topic: not remapped.
        assert_eq!(c.resolve("/joint_states"), "/joint_states");
        assert_eq!(c.resolve("robot_description"), "/cell/robot_description");
        assert_eq!(c.resolve("~/start"), "/cell/robot/start");
    }

    #[test]
    fn unknown_arguments_and_bad_values_are_refused_with_their_name() {
        let e = RosArgs::parse(&args(&["--enclave", "/x"])).unwrap_err();
        assert!(e.to_string().contains("--enclave"), "{e}");
        assert!(RosArgs::parse(&args(&["-r", "nothing"])).is_err());
        assert!(RosArgs::parse(&args(&["-p"])).is_err());
        let a = RosArgs::parse(&args(&["-p", "no_such_setting:=1"])).unwrap();
        let e = NodeConfig::default().apply_ros_args(&a).unwrap_err();
        assert!(e.to_string().contains("no_such_setting"), "{e}");
    }
}
