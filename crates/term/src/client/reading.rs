//! Reading the controller's text: the question pending among the last lines, the parts of a
//! `LOAD`'s text (programs echoed, the last line, the error count), a command's output without
//! its echo and prompt. Pure functions of text.

use crate::text;

/// A question the controller asked and how the client answered it.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum Question {
    /// `Are you sure ? (Yes:1, No:0)`.
    AreYouSure,
    /// A syntax error in the middle of a `LOAD`, with the line the controller quoted.
    SyntaxError(String),
    /// `Confirm !`.
    Confirm,
    /// `Press SPACE key to continue.`
    MorePages,
    /// `Load? (1:Yes, 0:No, 2:Load all, 3:Exit)` (answered **3**: the load ends).
    LoadQuery,
    /// `Force load` about a file's `.NETCONF` address (answered **0**: the load stops).
    ForceLoad,
    /// `Press ENTER.` (answered with a line end).
    PressEnter,
    /// `Change? (If not, Hit RETURN only)` after values offered for editing (`HERE`,
    /// `POINT`; answered with a line end: the values stay as shown).
    Change,
}

/// The last line of a text before its prompt.
pub(super) fn last_line(s: &str) -> &str {
    s.trim_end_matches('>')
        .trim_end()
        .lines()
        .last()
        .unwrap_or("")
}

/// Lines of the last ones looked at for a question: unsolicited lines may follow it.
const QUESTION_LINES: usize = 6;

/// The question pending at the end of `tail`: the last of its last lines that is a question,
/// with only whole lines (unsolicited output) after it and no prompt; with the text up to
/// and including the question's line.
pub(super) fn pending_question(tail: &str) -> Option<(Question, String)> {
    let lines: Vec<&str> = tail.split('\n').collect();
    let n = lines.len();
    for k in (n.saturating_sub(QUESTION_LINES)..n).rev() {
        let line = lines[k].trim_matches(['\r', ' ']);
        if line.starts_with('>') {
            return None;
        }
        if let Some(q) = classify(line) {
            // The question's own line must be the last, or be followed by whole lines only.
            let context = lines[..=k].join("\n");
            return Some((q, context));
        }
    }
    None
}

/// What kind of question a line is.
pub(super) fn classify(line: &str) -> Option<Question> {
    if line.is_empty() {
        return None;
    }
    if text::is_yes_no_question(line) {
        return Some(Question::AreYouSure);
    }
    if line.ends_with(')') && line.contains(text::DELETE_AND_ABORT_MARK) {
        return Some(Question::SyntaxError(String::new()));
    }
    if line.contains("3:Exit") || line.starts_with("Load?") {
        return Some(Question::LoadQuery);
    }
    if line.contains(text::FORCE_LOAD_MARK) {
        return Some(Question::ForceLoad);
    }
    if line.ends_with(text::CONFIRM) {
        return Some(Question::Confirm);
    }
    if line.trim_start().starts_with("Change?") {
        return Some(Question::Change);
    }
    if line.ends_with(text::PRESS_ENTER) {
        return Some(Question::PressEnter);
    }
    if line.ends_with(text::PRESS_SPACE) {
        return Some(Question::MorePages);
    }
    None
}

/// The step a syntax error quotes: the last line before the question that is not part of it.
pub(super) fn quoted_step(context: &str) -> String {
    context
        .lines()
        .map(str::trim)
        .rfind(|l| {
            !l.is_empty()
                && !l.contains(text::DELETE_AND_ABORT_MARK)
                && *l != text::SYNTAX_ERROR
                && !l.starts_with("Loading...")
        })
        .unwrap_or(text::SYNTAX_ERROR)
        .to_owned()
}

/// The programs a load's text says were loaded (`Program name(…)`), lower case.
pub(super) fn loaded_programs(s: &str) -> Vec<String> {
    s.lines()
        .filter_map(|l| {
            let rest = l.trim().strip_prefix("Program ")?;
            let (name, _) = rest.split_once('(')?;
            let name = name.trim();
            (!name.is_empty() && !name.contains(' ')).then(|| name.to_ascii_lowercase())
        })
        .collect()
}

/// The last line of a load, when it came.
pub(super) fn load_ending(s: &str) -> Option<String> {
    s.lines()
        .map(str::trim)
        .rfind(|l| l.starts_with(text::LOAD_COMPLETED_MARK) || l.starts_with(text::LOADING_DONE))
        .map(str::to_owned)
}

/// `N` of `File load completed. (N errors)`.
pub(super) fn completed_errors(s: &str) -> Option<usize> {
    let rest = &s[s.rfind(text::LOAD_COMPLETED_MARK)?..];
    let open = rest.find('(')?;
    rest[open + 1..]
        .split_whitespace()
        .next()
        .and_then(|n| n.parse().ok())
}

/// The output of a command: its echo line and the final prompt removed, CR dropped, lines
/// joined by `\n`.
pub(super) fn strip_echo(all: &str, command: &str) -> String {
    let body = all.strip_suffix('>').unwrap_or(all);
    let mut lines: Vec<&str> = body.split('\n').map(|l| l.trim_end_matches('\r')).collect();
    // The echo; lines before it were printed by a program while the command was on its way.
    if let Some(i) = lines
        .iter()
        .position(|l| !command.is_empty() && l.trim().eq_ignore_ascii_case(command.trim()))
    {
        lines.drain(..=i);
    }
    while lines.last().is_some_and(|l| l.trim().is_empty()) {
        lines.pop();
    }
    while lines.first().is_some_and(|l| l.trim().is_empty()) {
        lines.remove(0);
    }
    lines.join("\n")
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_question_is_found_under_unsolicited_lines_but_not_before_a_prompt() {
        let tail = "KILL\r\nAre you sure ? (Yes:1, No:0) \r\nProgram completed.No = 1\r\n";
        let (q, context) = pending_question(tail).expect("the question");
        assert_eq!(q, Question::AreYouSure);
        assert!(context.ends_with("(Yes:1, No:0) \r"), "{context:?}");
        assert_eq!(
            pending_question("Are you sure ? (Yes:1, No:0) 1\r\n(P1026)x\r\n>"),
            None
        );
        assert_eq!(pending_question("Program list\r\nx y\r\n"), None);
    }

    #[test]
    fn each_question_of_a_load_is_told_apart() {
        assert_eq!(classify(text::LOAD_QUERY), Some(Question::LoadQuery));
        assert_eq!(
            classify("Force load ? (9:Yes, 0:No)"),
            Some(Question::ForceLoad)
        );
        assert_eq!(classify(text::PRESS_ENTER), Some(Question::PressEnter));
        assert_eq!(classify(text::CHANGE_QUESTION), Some(Question::Change));
        assert_eq!(
            classify("Change?(if not, hit RETURN only)"),
            Some(Question::Change)
        );
        assert_eq!(classify(text::CONFIRM), Some(Question::Confirm));
        assert_eq!(classify(text::PRESS_SPACE), Some(Question::MorePages));
        assert!(matches!(
            classify(text::SYNTAX_ERROR_CHOICES),
            Some(Question::SyntaxError(_))
        ));
        assert_eq!(classify("Program x()"), None);
    }

    #[test]
    fn a_loads_text_gives_its_programs_its_last_line_and_its_count() {
        let s = "Loading...(d.as)\r\nProgram Autostart.pc()\r\nProgram ros_move (.a)\r\nFile load completed. (2 errors)\r\n>";
        assert_eq!(loaded_programs(s), ["autostart.pc", "ros_move"]);
        assert_eq!(
            load_ending(s).as_deref(),
            Some("File load completed. (2 errors)")
        );
        assert_eq!(completed_errors(s), Some(2));
        assert_eq!(
            load_ending("Program a()\r\nLoading done.\r\n>").as_deref(),
            Some("Loading done.")
        );
    }
}
