//! The interface panel (AS-E p.6-96…6-100, p.5-114…5-118): `IFPWPRINT` and `IFPWOVERWRITE`
//! write strings to its windows, `IFPLABEL` names its icons, `IFPTITLE` its pages. The
//! emulator has no panel to draw on: it keeps what a panel would show, for observers
//! ([`Interpreter::interface_panel`]), and the program goes on as on a controller with one.

use std::collections::BTreeMap;

use serde::Serialize;

use crate::compile::{IfpWriteOp, RExpr, SExpr};
use crate::error::RuntimeError;
use crate::system::System;

use super::arith::R;
use super::task::{Flow, TaskSlot};
use super::Interpreter;

/// Windows of the panel (1–8, "standard").
const PANEL_WINDOWS: usize = 8;
/// Rows a window holds (the manual's largest: 1–4).
const WINDOW_ROWS: usize = 4;
/// Columns a row holds (the manual's largest: `IFPWOVERWRITE`'s 1–78).
const WINDOW_COLUMNS: usize = 78;
/// Icon positions (1–112).
const ICON_POSITIONS: usize = 112;

/// One string window of the interface panel.
#[derive(Debug, Clone, PartialEq, Eq, Serialize)]
pub struct PanelWindow {
    /// The rows as shown, trailing blanks removed (control characters shown as blanks).
    pub rows: [String; WINDOW_ROWS],
    /// The row, column and colours last used (the defaults of the next write that omits them):
    /// row 1, column 1, background 7 (white), label colour 10 (black).
    pub row: u8,
    /// See [`PanelWindow::row`].
    pub column: u8,
    /// Background colour, 0–15 (AS-E p.5-114's table).
    pub background: u8,
    /// Label (character) colour, 0–15.
    pub label_colour: u8,
}

impl Default for PanelWindow {
    fn default() -> Self {
        PanelWindow {
            rows: Default::default(),
            row: 1,
            column: 1,
            background: 7,
            label_colour: 10,
        }
    }
}

/// What the interface panel shows.
#[derive(Debug, Clone, Default, PartialEq, Eq, Serialize)]
pub struct InterfacePanel {
    /// Windows 1–8 (index 0 is window 1).
    pub windows: [PanelWindow; PANEL_WINDOWS],
    /// Icon labels by position (1–112), four each; only positions a program labelled.
    pub labels: BTreeMap<u8, [String; 4]>,
    /// Page titles by page number; only pages a program titled.
    pub titles: BTreeMap<u32, String>,
}

impl PanelWindow {
    /// Writes `texts` from `row`, `column` (1-based): each string on the next row, a string
    /// longer than the row going on at `column` of the next; what falls outside is not shown.
    /// `clear`: the other rows are emptied (`IFPWPRINT`); else only the rows written change.
    fn write(&mut self, row: usize, column: usize, texts: &[Vec<u8>], clear: bool) {
        let mut grid: Vec<Vec<u8>> = self
            .rows
            .iter()
            .map(|r| {
                let mut v = if clear {
                    Vec::new()
                } else {
                    r.as_bytes().to_vec()
                };
                v.resize(WINDOW_COLUMNS, b' ');
                v
            })
            .collect();
        let mut r = row - 1;
        for text in texts {
            if r >= WINDOW_ROWS {
                break;
            }
            grid[r] = vec![b' '; WINDOW_COLUMNS];
            let mut c = column - 1;
            for &b in text {
                if c >= WINDOW_COLUMNS {
                    r += 1;
                    if r >= WINDOW_ROWS {
                        break;
                    }
                    grid[r] = vec![b' '; WINDOW_COLUMNS];
                    c = column - 1;
                }
                grid[r][c] = if b.is_ascii_control() { b' ' } else { b };
                c += 1;
            }
            r += 1;
        }
        for (shown, row) in self.rows.iter_mut().zip(grid) {
            *shown = String::from_utf8_lossy(&row).trim_end().to_owned();
        }
    }
}

impl Interpreter {
    /// What the interface panel shows now.
    pub fn interface_panel(&self) -> &InterfacePanel {
        &self.panel
    }

    /// `IFPWPRINT` (`overwrite` false) and `IFPWOVERWRITE`.
    pub(super) fn ifp_write(
        &mut self,
        i: TaskSlot,
        overwrite: bool,
        w: &IfpWriteOp,
        sys: &mut dyn System,
    ) -> R<Flow> {
        let what = if overwrite {
            "IFPWOVERWRITE"
        } else {
            "IFPWPRINT"
        };
        let window = self.panel_number(i, &w.window, sys, what, "window", PANEL_WINDOWS)?;
        let last = &self.panel.windows[window - 1];
        let defaults = [last.row, last.column, last.background, last.label_colour];
        let max_column = if overwrite { WINDOW_COLUMNS } else { 70 };
        let limits = [
            ("row", 1, WINDOW_ROWS),
            ("column", 1, max_column),
            ("background colour", 0, 15),
            ("label colour", 0, 15),
        ];
        let mut place = defaults;
        for ((slot, e), (name, low, high)) in place.iter_mut().zip(&w.place).zip(limits) {
            if let Some(e) = e {
                let v = self.eval_r(i, e, sys)?.trunc();
                if !(low as f32..=high as f32).contains(&v) {
                    return Err(Box::new(RuntimeError::IllegalValue(format!(
                        "{what} {name} {v} (from {low} to {high})"
                    ))));
                }
                *slot = v as u8;
            }
        }
        let mut texts = Vec::with_capacity(w.texts.len());
        for t in &w.texts {
            texts.push(self.eval_s(i, t, sys)?.to_vec());
        }
        let [row, column, background, label_colour] = place;
        let win = &mut self.panel.windows[window - 1];
        win.write(usize::from(row), usize::from(column), &texts, !overwrite);
        win.row = row;
        win.column = column;
        win.background = background;
        win.label_colour = label_colour;
        Ok(Flow::Next)
    }

    /// `IFPLABEL position, labels…`: a label given replaces the icon's, one omitted stays.
    pub(super) fn ifp_label(
        &mut self,
        i: TaskSlot,
        position: &RExpr,
        labels: &[Option<SExpr>],
        sys: &mut dyn System,
    ) -> R<Flow> {
        let position =
            self.panel_number(i, position, sys, "IFPLABEL", "position", ICON_POSITIONS)?;
        let mut given = Vec::with_capacity(labels.len());
        for l in labels {
            given.push(match l {
                Some(e) => Some(self.eval_s(i, e, sys)?),
                None => None,
            });
        }
        let entry = self.panel.labels.entry(position as u8).or_default();
        for (slot, label) in entry.iter_mut().zip(given) {
            if let Some(label) = label {
                *slot = String::from_utf8_lossy(&label).into_owned();
            }
        }
        Ok(Flow::Next)
    }

    /// `IFPTITLE page, title`.
    pub(super) fn ifp_title(
        &mut self,
        i: TaskSlot,
        page: &RExpr,
        title: &SExpr,
        sys: &mut dyn System,
    ) -> R<Flow> {
        let page = self.panel_number(i, page, sys, "IFPTITLE", "page", u32::MAX as usize)?;
        let title = self.eval_s(i, title, sys)?;
        self.panel
            .titles
            .insert(page as u32, String::from_utf8_lossy(&title).into_owned());
        Ok(Flow::Next)
    }

    /// A window, icon or page number from 1 to `max`, else E0106.
    fn panel_number(
        &mut self,
        i: TaskSlot,
        e: &RExpr,
        sys: &mut dyn System,
        what: &str,
        name: &str,
        max: usize,
    ) -> R<usize> {
        let v = self.eval_r(i, e, sys)?.trunc();
        if v < 1.0 || f64::from(v) > max as f64 {
            return Err(Box::new(RuntimeError::IllegalValue(format!(
                "{what} {name} {v} (from 1 to {max})"
            ))));
        }
        Ok(v as usize)
    }
}
