//! A picture of a run: one panel per joint (commanded against actual), the tracking error, the
//! round-trip histogram with the late replies, and a title with robot, date and duration.
//!
//! Drawn with `plotters` (PNG through the `png` crate, or SVG). Text uses a font shipped as a
//! dependency (Ubuntu Light from `epaint_default_fonts`), registered in-process: no system fonts
//! or libraries are needed.

use std::path::Path;
use std::sync::OnceLock;

use plotters::coord::Shift;
use plotters::prelude::*;
use serde::Serialize;

use crate::error::RecordError;
use crate::read::{Run, SourceFormat};

/// Image formats.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
pub enum ImageFormat {
    /// PNG (RGB, 8 bits).
    Png,
    /// SVG.
    Svg,
}

impl ImageFormat {
    /// The format a file name asks for (`.png`, `.svg`).
    pub fn from_path(path: &Path) -> Option<ImageFormat> {
        match path.extension()?.to_str()?.to_ascii_lowercase().as_str() {
            "png" => Some(ImageFormat::Png),
            "svg" => Some(ImageFormat::Svg),
            _ => None,
        }
    }
}

/// What to draw.
#[derive(Debug, Clone, PartialEq)]
pub struct PlotOptions {
    /// Joints to draw, 1–6 (default all six).
    pub joints: Vec<usize>,
    /// Start of the window, seconds since the recording started (default: the first sample).
    pub from_s: Option<f64>,
    /// End of the window (default: the last sample).
    pub to_s: Option<f64>,
    /// Image width, pixels.
    pub width: u32,
    /// Image height, pixels (`None`: from the number of panels).
    pub height: Option<u32>,
    /// A name for the title (e.g. the file name).
    pub name: Option<String>,
}

impl Default for PlotOptions {
    fn default() -> Self {
        PlotOptions {
            joints: (1..=6).collect(),
            from_s: None,
            to_s: None,
            width: 1600,
            height: None,
            name: None,
        }
    }
}

/// Largest image side accepted, pixels.
pub const MAX_SIDE: u32 = 8000;

/// What was drawn.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct PlotSummary {
    /// Panels drawn: one per joint, the tracking error, the round trips.
    pub panels: usize,
    /// Image width, pixels.
    pub width: u32,
    /// Image height, pixels.
    pub height: u32,
    /// The time window, seconds since the recording started.
    pub from_s: f64,
    /// End of the window.
    pub to_s: f64,
    /// Measured samples in the window.
    pub states: usize,
    /// Commanded positions in the window.
    pub commanded: usize,
    /// Round trips in the window.
    pub round_trips: usize,
    /// Of them, late (slower than the recording's threshold).
    pub late_replies: usize,
}

/// Caption prefixes of the panels (tests and users can find the panels in an SVG by them).
pub const JOINT_PANEL_CAPTION: &str = "joint";
/// Caption of the tracking-error panel.
pub const TRACKING_PANEL_CAPTION: &str = "tracking error";
/// Caption prefix of the round-trip panel.
pub const RTT_PANEL_CAPTION: &str = "round trip";

const TITLE_H: u32 = 64;
const JOINT_PANEL_H: u32 = 280;
const BOTTOM_PANEL_H: u32 = 320;
/// Points per line at most (min/max per bucket beyond that).
const MAX_POINTS: usize = 4000;

const ACTUAL: RGBColor = RGBColor(31, 119, 180);
const COMMANDED: RGBColor = RGBColor(255, 127, 14);
const LATE: RGBColor = RGBColor(214, 39, 40);
const JOINT_COLORS: [RGBColor; 6] = [
    RGBColor(31, 119, 180),
    RGBColor(255, 127, 14),
    RGBColor(44, 160, 44),
    RGBColor(214, 39, 40),
    RGBColor(148, 103, 189),
    RGBColor(140, 86, 75),
];

fn fonts() -> Result<(), RecordError> {
    static REGISTERED: OnceLock<bool> = OnceLock::new();
    let ok = *REGISTERED.get_or_init(|| {
        plotters::style::register_font(
            "sans-serif",
            FontStyle::Normal,
            epaint_default_fonts::UBUNTU_LIGHT,
        )
        .is_ok()
    });
    if ok {
        Ok(())
    } else {
        Err(RecordError::Draw(
            "the bundled font cannot be loaded".into(),
        ))
    }
}

/// The data of one picture, cut to the window.
struct Prepared<'a> {
    run: &'a Run,
    joints: Vec<usize>,
    from: f64,
    to: f64,
    width: u32,
    height: u32,
    title: String,
}

impl PlotOptions {
    fn prepare<'a>(&self, run: &'a Run) -> Result<Prepared<'a>, RecordError> {
        let mut joints = self.joints.clone();
        joints.sort_unstable();
        joints.dedup();
        if joints.is_empty() || joints.iter().any(|j| !(1..=6).contains(j)) {
            return Err(RecordError::Options(format!(
                "joints {:?}: give joint numbers from 1 to 6, e.g. --joints 1,2",
                self.joints
            )));
        }
        if run.states.is_empty() && run.exchanges.is_empty() {
            return Err(RecordError::Empty(
                "the recording holds no replies: nothing to plot".into(),
            ));
        }
        let (first, last) = run.time_span();
        let from = self.from_s.unwrap_or(first);
        let to = self.to_s.unwrap_or(last);
        if !(from.is_finite() && to.is_finite()) || to <= from {
            return Err(RecordError::Options(format!(
                "the window {from:.3} s to {to:.3} s is empty (the recording spans {first:.3} s \
                 to {last:.3} s): give --from below --to"
            )));
        }
        let rows = joints.len().div_ceil(2) as u32;
        let height = self
            .height
            .unwrap_or(TITLE_H + rows * JOINT_PANEL_H + BOTTOM_PANEL_H);
        for (name, v) in [("width", self.width), ("height", height)] {
            if !(200..=MAX_SIDE).contains(&v) {
                return Err(RecordError::Options(format!(
                    "image {name} {v} px: give 200 to {MAX_SIDE}"
                )));
            }
        }
        let date = run.info.as_ref().map(|i| {
            format!(
                "{} UTC",
                i.started_utc
                    .replace('T', " ")
                    .get(..19)
                    .unwrap_or_default()
            )
        });
        let mut title = String::from("FS020N");
        if let Some(name) = &self.name {
            title.push_str(&format!("  |  {name}"));
        }
        title.push_str(&format!(
            "  |  robot {}",
            run.robot().unwrap_or(match run.format {
                SourceFormat::StatusCsv => "(status CSV)",
                _ => "(unknown)",
            })
        ));
        if let Some(d) = date {
            title.push_str(&format!("  |  {d}"));
        }
        title.push_str(&format!("  |  {:.1} s", last - first));
        if self.from_s.is_some() || self.to_s.is_some() {
            title.push_str(&format!(" (showing {from:.1} to {to:.1} s)"));
        }
        if run.truncated.is_some() {
            title.push_str("  |  file cut short");
        }
        Ok(Prepared {
            run,
            joints,
            from,
            to,
            width: self.width,
            height,
            title,
        })
    }
}

/// Draws `run` into `path` (PNG or SVG by extension).
pub fn plot_to_file(
    run: &Run,
    path: &Path,
    opts: &PlotOptions,
) -> Result<PlotSummary, RecordError> {
    let format = ImageFormat::from_path(path).ok_or_else(|| {
        RecordError::Options(format!("{}: name the image .png or .svg", path.display()))
    })?;
    let (bytes, summary) = render(run, format, opts)?;
    std::fs::write(path, bytes).map_err(|e| RecordError::Io {
        path: path.display().to_string(),
        message: e.to_string(),
    })?;
    Ok(summary)
}

/// Draws `run` as PNG or SVG bytes.
pub fn render(
    run: &Run,
    format: ImageFormat,
    opts: &PlotOptions,
) -> Result<(Vec<u8>, PlotSummary), RecordError> {
    fonts()?;
    let p = opts.prepare(run)?;
    let (w, h) = (p.width, p.height);
    match format {
        ImageFormat::Svg => {
            let mut svg = String::new();
            let summary = {
                let root = SVGBackend::with_string(&mut svg, (w, h)).into_drawing_area();
                let s = draw(&root, &p)?;
                root.present().map_err(draw_err)?;
                s
            };
            Ok((svg.into_bytes(), summary))
        }
        ImageFormat::Png => {
            let mut rgb = vec![0u8; w as usize * h as usize * 3];
            let summary = {
                let root = BitMapBackend::with_buffer(&mut rgb, (w, h)).into_drawing_area();
                let s = draw(&root, &p)?;
                root.present().map_err(draw_err)?;
                s
            };
            let mut out = Vec::new();
            {
                let mut enc = png::Encoder::new(&mut out, w, h);
                enc.set_color(png::ColorType::Rgb);
                enc.set_depth(png::BitDepth::Eight);
                let mut writer = enc
                    .write_header()
                    .map_err(|e| RecordError::Draw(e.to_string()))?;
                writer
                    .write_image_data(&rgb)
                    .map_err(|e| RecordError::Draw(e.to_string()))?;
            }
            Ok((out, summary))
        }
    }
}

fn draw_err<E: std::fmt::Display>(e: E) -> RecordError {
    RecordError::Draw(e.to_string())
}

/// Keeps at most [`MAX_POINTS`] points: the first, lowest and highest of each bucket, in time
/// order, so that spikes stay visible.
fn decimate(points: Vec<(f64, f64)>) -> Vec<(f64, f64)> {
    if points.len() <= MAX_POINTS {
        return points;
    }
    let per = points.len().div_ceil(MAX_POINTS / 3);
    let mut out = Vec::with_capacity(MAX_POINTS + 3);
    for bucket in points.chunks(per) {
        let first = bucket[0];
        let lo = bucket
            .iter()
            .copied()
            .min_by(|a, b| a.1.total_cmp(&b.1))
            .unwrap_or(first);
        let hi = bucket
            .iter()
            .copied()
            .max_by(|a, b| a.1.total_cmp(&b.1))
            .unwrap_or(first);
        let mut three = [first, lo, hi];
        three.sort_by(|a, b| a.0.total_cmp(&b.0));
        out.extend_from_slice(&three);
    }
    out
}

fn range(values: impl Iterator<Item = f64>) -> (f64, f64) {
    let (lo, hi) = values
        .filter(|v| v.is_finite())
        .fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), v| {
            (lo.min(v), hi.max(v))
        });
    if !lo.is_finite() {
        return (-1.0, 1.0);
    }
    let pad = ((hi - lo) * 0.08).max(0.5);
    (lo - pad, hi + pad)
}

/// The streamed position at `t`: the latest command-7 sample at or before `t`, moved on by its
/// velocity as the controller extrapolates it (at most [`STREAM_HOLD_S`]). `None` outside a
/// stream: a joint move's target is where the arm goes, not where it should be now.
fn streamed_at(run: &Run, idx: &mut usize, t: f64) -> Option<[f64; 6]> {
    let c = &run.commanded;
    while *idx + 1 < c.len() && c[*idx + 1].t_s <= t {
        *idx += 1;
    }
    let cur = c.get(*idx).filter(|c| c.t_s <= t && c.streamed)?;
    let dt = t - cur.t_s;
    if dt > STREAM_HOLD_S {
        return None;
    }
    let mut p = cur.joints_deg;
    if let Some(v) = cur.velocity_deg_s {
        for (pi, vi) in p.iter_mut().zip(v) {
            *pi += vi * dt;
        }
    }
    Some(p)
}

/// How long a streamed sample stands for the commanded position (the controller's clamp).
const STREAM_HOLD_S: f64 = 0.5;

fn draw<DB: DrawingBackend>(
    root: &DrawingArea<DB, Shift>,
    p: &Prepared<'_>,
) -> Result<PlotSummary, RecordError> {
    let run = p.run;
    let (from, to) = (p.from, p.to);
    let inside = |t: f64| t >= from && t <= to;
    root.fill(&WHITE).map_err(draw_err)?;
    let (title, rest) = root.split_vertically(TITLE_H);
    title
        .draw_text(
            &p.title,
            &("sans-serif", 26).into_font().color(&BLACK),
            (16, 20),
        )
        .map_err(draw_err)?;
    let rows = p.joints.len().div_ceil(2);
    let cols = if p.joints.len() == 1 { 1 } else { 2 };
    let joint_h = rest
        .dim_in_pixel()
        .1
        .saturating_sub(BOTTOM_PANEL_H.min(rest.dim_in_pixel().1 / 2));
    let (joint_area, bottom) = rest.split_vertically(joint_h);
    let panels = joint_area.split_evenly((rows, cols));
    let states: Vec<_> = run.states.iter().filter(|s| inside(s.t_s)).collect();
    let commanded_in: Vec<_> = run.commanded.iter().filter(|c| inside(c.t_s)).collect();
    let time_axis = from..to;

    for (panel, &j) in panels.iter().zip(&p.joints) {
        let k = j - 1;
        let actual: Vec<(f64, f64)> = states.iter().map(|s| (s.t_s, s.joints_deg[k])).collect();
        // Commanded as steps: each value holds until the next one.
        let mut steps = Vec::with_capacity(commanded_in.len() * 2 + 1);
        let relevant = run
            .commanded
            .iter()
            .enumerate()
            .filter(|(i, c)| {
                inside(c.t_s)
                    || (c.t_s < from && run.commanded.get(i + 1).is_none_or(|n| n.t_s > from))
            })
            .map(|(_, c)| c)
            .collect::<Vec<_>>();
        for (i, c) in relevant.iter().enumerate() {
            let start = c.t_s.max(from);
            let next = relevant.get(i + 1);
            steps.push((start, c.joints_deg[k]));
            // Streamed samples follow each other as a line (the controller moves between
            // them); a joint-move target holds until the next command.
            let streaming =
                next.is_some_and(|n| c.streamed && n.streamed && n.t_s - c.t_s <= STREAM_HOLD_S);
            if !streaming {
                let end = next.map_or(to, |n| n.t_s).min(to);
                steps.push((end, c.joints_deg[k]));
            }
        }
        let (lo, hi) = range(actual.iter().map(|p| p.1).chain(steps.iter().map(|p| p.1)));
        let mut chart = ChartBuilder::on(panel)
            .caption(
                format!("{JOINT_PANEL_CAPTION} {j} (deg)"),
                ("sans-serif", 18),
            )
            .margin(10)
            .x_label_area_size(40)
            .y_label_area_size(56)
            .build_cartesian_2d(time_axis.clone(), lo..hi)
            .map_err(draw_err)?;
        chart
            .configure_mesh()
            .x_desc("time (s)")
            .label_style(("sans-serif", 13))
            .draw()
            .map_err(draw_err)?;
        if !steps.is_empty() {
            chart
                .draw_series(LineSeries::new(decimate(steps), COMMANDED.stroke_width(2)))
                .map_err(draw_err)?
                .label("commanded")
                .legend(|(x, y)| {
                    PathElement::new(vec![(x, y), (x + 18, y)], COMMANDED.stroke_width(2))
                });
        }
        chart
            .draw_series(LineSeries::new(decimate(actual), ACTUAL.stroke_width(2)))
            .map_err(draw_err)?
            .label("actual")
            .legend(|(x, y)| PathElement::new(vec![(x, y), (x + 18, y)], ACTUAL.stroke_width(2)));
        chart
            .configure_series_labels()
            .position(SeriesLabelPosition::UpperRight)
            .label_font(("sans-serif", 13))
            .background_style(WHITE.mix(0.8))
            .border_style(BLACK.mix(0.4))
            .draw()
            .map_err(draw_err)?;
    }

    let halves = bottom.split_evenly((1, 2));
    // Tracking error: streamed position minus actual, per joint.
    let mut idx = 0;
    let mut errors: Vec<Vec<(f64, f64)>> = vec![Vec::new(); p.joints.len()];
    for s in &states {
        if let Some(c) = streamed_at(run, &mut idx, s.t_s) {
            for (e, &j) in errors.iter_mut().zip(&p.joints) {
                e.push((s.t_s, c[j - 1] - s.joints_deg[j - 1]));
            }
        }
    }
    let (lo, hi) = range(errors.iter().flatten().map(|p| p.1));
    let mut chart = ChartBuilder::on(&halves[0])
        .caption(
            format!("{TRACKING_PANEL_CAPTION} of streamed samples: commanded − actual (deg)"),
            ("sans-serif", 18),
        )
        .margin(10)
        .x_label_area_size(40)
        .y_label_area_size(56)
        .build_cartesian_2d(time_axis, lo..hi)
        .map_err(draw_err)?;
    chart
        .configure_mesh()
        .x_desc("time (s)")
        .label_style(("sans-serif", 13))
        .draw()
        .map_err(draw_err)?;
    if errors.iter().all(Vec::is_empty) {
        halves[0]
            .draw_text(
                "no streamed samples (command 7) in this window",
                &("sans-serif", 16).into_font().color(&BLACK.mix(0.6)),
                (80, 150),
            )
            .map_err(draw_err)?;
    } else {
        for (e, &j) in errors.into_iter().zip(&p.joints) {
            let color = JOINT_COLORS[j - 1];
            chart
                .draw_series(LineSeries::new(decimate(e), color.stroke_width(1)))
                .map_err(draw_err)?
                .label(format!("J{j}"))
                .legend(move |(x, y)| {
                    PathElement::new(vec![(x, y), (x + 18, y)], color.stroke_width(2))
                });
        }
        chart
            .configure_series_labels()
            .position(SeriesLabelPosition::UpperRight)
            .label_font(("sans-serif", 13))
            .background_style(WHITE.mix(0.8))
            .border_style(BLACK.mix(0.4))
            .draw()
            .map_err(draw_err)?;
    }

    // Round trips: a histogram; late replies in red, with the threshold.
    let late_ms = run.late_reply_after_ms();
    let rtts: Vec<(f64, f64)> = run
        .exchanges
        .iter()
        .filter(|e| inside(e.sent_s))
        .filter_map(|e| e.rtt_ms.map(|r| (e.sent_s, r)))
        .collect();
    let late: Vec<f64> = rtts.iter().filter(|r| r.1 > late_ms).map(|r| r.0).collect();
    let caption = if rtts.is_empty() {
        format!("{RTT_PANEL_CAPTION} (ms): none recorded")
    } else {
        let mut sorted: Vec<f64> = rtts.iter().map(|r| r.1).collect();
        sorted.sort_by(f64::total_cmp);
        let n = sorted.len();
        let mean = sorted.iter().sum::<f64>() / n as f64;
        let p99 = sorted[((n as f64 * 0.99).ceil() as usize).clamp(1, n) - 1];
        format!(
            "{RTT_PANEL_CAPTION} (ms): n {n}, mean {mean:.2}, p99 {p99:.2}, max {:.2}; late (> {late_ms:.0} ms) {}",
            sorted[n - 1],
            late.len()
        )
    };
    let max_ms = rtts.iter().map(|r| r.1).fold(0.0f64, f64::max).max(0.05) * 1.05;
    const BINS: usize = 40;
    let width = max_ms / BINS as f64;
    let mut counts = [0u32; BINS];
    for r in &rtts {
        counts[((r.1 / width) as usize).min(BINS - 1)] += 1;
    }
    let top = f64::from(counts.iter().copied().max().unwrap_or(0).max(1)) * 1.1;
    let mut chart = ChartBuilder::on(&halves[1])
        .caption(caption, ("sans-serif", 18))
        .margin(10)
        .x_label_area_size(40)
        .y_label_area_size(56)
        .build_cartesian_2d(0.0..max_ms, 0.0..top)
        .map_err(draw_err)?;
    chart
        .configure_mesh()
        .x_desc("round trip (ms)")
        .y_desc("replies")
        .label_style(("sans-serif", 13))
        .draw()
        .map_err(draw_err)?;
    chart
        .draw_series(
            counts
                .iter()
                .enumerate()
                .filter(|(_, c)| **c > 0)
                .map(|(i, c)| {
                    let x0 = i as f64 * width;
                    let color = if x0 + width > late_ms { LATE } else { ACTUAL };
                    Rectangle::new([(x0, 0.0), (x0 + width, f64::from(*c))], color.filled())
                }),
        )
        .map_err(draw_err)?;
    if late_ms < max_ms {
        chart
            .draw_series(LineSeries::new(
                vec![(late_ms, 0.0), (late_ms, top)],
                LATE.stroke_width(2),
            ))
            .map_err(draw_err)?;
    }
    if !late.is_empty() {
        let list: Vec<String> = late.iter().take(6).map(|t| format!("{t:.1}")).collect();
        let more = if late.len() > 6 { ", …" } else { "" };
        halves[1]
            .draw_text(
                &format!("late replies at {} s{more}", list.join(", ")),
                &("sans-serif", 14).into_font().color(&LATE),
                (80, 44),
            )
            .map_err(draw_err)?;
    }

    Ok(PlotSummary {
        panels: p.joints.len() + 2,
        width: p.width,
        height: p.height,
        from_s: from,
        to_s: to,
        states: states.len(),
        commanded: commanded_in.len(),
        round_trips: rtts.len(),
        late_replies: late.len(),
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn decimation_keeps_spikes_and_order() {
        let mut pts: Vec<(f64, f64)> = (0..100_000).map(|i| (i as f64, 0.0)).collect();
        pts[54_321].1 = 9.0;
        pts[77_777].1 = -4.0;
        let d = decimate(pts);
        assert!(d.len() <= MAX_POINTS + 3);
        assert!(d.iter().any(|p| p.1 == 9.0));
        assert!(d.iter().any(|p| p.1 == -4.0));
        assert!(d.windows(2).all(|w| w[0].0 <= w[1].0));
    }

    #[test]
    fn ranges_are_never_empty() {
        assert_eq!(range([].into_iter()), (-1.0, 1.0));
        let (lo, hi) = range([3.0, 3.0].into_iter());
        assert!(lo < 3.0 && hi > 3.0);
    }
}
