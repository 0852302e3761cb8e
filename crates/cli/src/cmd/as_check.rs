//! `fs020n as check FILE…`: loads each AS file exactly as the emulator would (the same loader
//! as `sim --as-program`), the files together as one controller memory, and reports errors,
//! warnings and the lint against the controller's limits, as text or one JSON object per file
//! per line.

use std::io::Write as _;

use fs020n_as::lint::{Finding, Generation, Severity};
use fs020n_as::{CheckReport, LoadOptions, ParseError};
use serde_json::{json, Value};

use crate::args::AsCheckArgs;
use crate::error::{CliError, CliResult};

fn position(e: &ParseError) -> Value {
    json!({"line": e.span.line, "column": e.span.col, "message": e.message})
}

fn finding(f: &Finding) -> Value {
    json!({
        "line": f.line,
        "column": f.column,
        "rule": f.rule,
        "severity": f.severity,
        "message": f.message,
    })
}

/// The JSON line of one file, its keys in the documented order (`file`, `loaded`, `errors`,
/// `warnings`, `lint`).
fn to_json(file: &str, r: &CheckReport) -> String {
    let list = |v: Vec<Value>| Value::Array(v).to_string();
    format!(
        "{{\"file\":{},\"loaded\":{},\"errors\":{},\"warnings\":{},\"lint\":{}}}",
        Value::from(file),
        r.loaded,
        list(r.errors.iter().map(position).collect()),
        list(r.warnings.iter().map(position).collect()),
        list(r.lint.iter().map(finding).collect()),
    )
}

/// The text of one file: one line per error, warning and finding (file:line:column), then a
/// summary line.
fn to_text(file: &str, r: &CheckReport) -> String {
    let mut out = String::new();
    for e in &r.errors {
        out.push_str(&format!("{file}:{}: error: {}\n", e.span, e.message));
    }
    for w in &r.warnings {
        out.push_str(&format!("{file}:{}: warning: {}\n", w.span, w.message));
    }
    for f in &r.lint {
        let level = match f.severity {
            Severity::Error => "lint error",
            Severity::Warning => "lint warning",
        };
        out.push_str(&format!(
            "{file}:{}:{}: {level} [{}]: {}\n",
            f.line, f.column, f.rule, f.message
        ));
    }
    let lint_errors = r
        .lint
        .iter()
        .filter(|f| f.severity == Severity::Error)
        .count();
    out.push_str(&if r.loaded {
        format!(
            "{file}: loads ({} warning(s), {} lint finding(s), {lint_errors} of them errors)\n",
            r.warnings.len(),
            r.lint.len()
        )
    } else {
        format!("{file}: does not load ({} error(s))\n", r.errors.len())
    });
    out
}

/// `as check`.
pub(crate) fn check(args: &AsCheckArgs, json: bool) -> CliResult {
    let generation = match &args.controller {
        Some(c) => Some(c.parse::<Generation>().map_err(CliError::input)?),
        None => None,
    };
    let opts = (args.stubs.iter()).fold(LoadOptions::new(), |o, s| o.stub(s));
    let (mut failed, mut unreadable) = (0usize, Vec::new());
    let mut stdout = std::io::stdout().lock();
    // The files are checked together, as one controller memory.
    let mut read = Vec::new();
    for path in &args.files {
        let file = path.display().to_string();
        match std::fs::read(path) {
            Ok(b) => read.push((file, b)),
            Err(e) => unreadable.push(format!("{file}: {e}")),
        }
    }
    let files: Vec<(&str, &[u8])> = read
        .iter()
        .map(|(f, b)| (f.as_str(), b.as_slice()))
        .collect();
    let reports = fs020n_as::check_memory(&files, &opts, generation);
    for ((file, _), report) in files.iter().zip(&reports) {
        if !report.passes() {
            failed += 1;
        }
        let text = if json {
            format!("{}\n", to_json(file, report))
        } else {
            to_text(file, report)
        };
        stdout
            .write_all(text.as_bytes())
            .map_err(|e| CliError::failure(format!("cannot write the report: {e}")))?;
    }
    if !unreadable.is_empty() {
        return Err(
            CliError::input(format!("cannot read {}", unreadable.join("; ")))
                .with_remedy("name AS files that exist and can be read"),
        );
    }
    if failed > 0 {
        return Err(CliError::failure(format!(
            "{failed} of {} file(s) do not load or are linted as an error",
            args.files.len()
        ))
        .with_remedy("fix the errors listed above (file:line:column); `--stub INSTR` declares an instruction a no-op"));
    }
    Ok(())
}
