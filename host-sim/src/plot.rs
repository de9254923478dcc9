//! `host-sim plot`: a recording and what the monitor made of it, as one SVG
//! an engineer can open in a browser: the pressures, the motion, the leak
//! estimates against the warning and alarm levels, and the hypotheses'
//! probabilities, with the alarms marked.
//!
//! The replay streams; the plot keeps a bounded number of points
//! ([`Decimator`]), so an hour-long recording plots in constant memory.

use crate::replay::{EventRecord, Observer, ReplaySummary};
use monitor::{Params, Sample, Status};
use plotters::coord::Shift;
use plotters::prelude::*;
use std::path::Path;

/// Most points kept per series: far more than a screen's width, few enough
/// for a light SVG.
pub const MAX_POINTS: usize = 4000;

/// One plotted instant. Missing readings and estimates are NaN (gaps).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Point {
    /// Time, s.
    pub t_s: f64,
    /// Supply, piston-chamber, rod-chamber and tank pressure, bar.
    pub p_bar: [f32; 4],
    /// Piston position, mm.
    pub x_mm: f32,
    /// Valve command, % of full scale.
    pub u_pct: f32,
    /// Leak flow estimates (internal, external), l/min, over the evidence
    /// window (the reported size).
    pub leak_lpm: [f32; 2],
    /// Leak flows over the short detection window, l/min.
    pub detect_lpm: [f32; 2],
    /// Probabilities of healthy, internal, external, both.
    pub probability: [f32; 4],
    /// Evidence weight, 0..1.
    pub evidence_weight: f32,
}

/// Keeps at most `2 × max` evenly strided points of a stream of unknown
/// length: when full, every other point is dropped and the stride doubles.
#[derive(Clone, Debug)]
pub struct Decimator {
    max: usize,
    stride: u64,
    seen: u64,
    points: Vec<Point>,
}

impl Decimator {
    /// A decimator keeping about `max` points (between `max` and `2 × max`
    /// once the stream is longer than that).
    pub fn new(max: usize) -> Self {
        Self {
            max: max.max(2),
            stride: 1,
            seen: 0,
            points: Vec::new(),
        }
    }

    /// Offer the next point of the stream.
    pub fn push(&mut self, p: Point) {
        if self.seen.is_multiple_of(self.stride) {
            self.points.push(p);
            if self.points.len() >= 2 * self.max {
                // Keep the points at even multiples of the new stride.
                let mut k = 0;
                self.points.retain(|_| {
                    k += 1;
                    k % 2 == 1
                });
                self.stride *= 2;
            }
        }
        self.seen += 1;
    }

    /// The kept points, in time order.
    pub fn points(&self) -> &[Point] {
        &self.points
    }
}

/// An alarm or sensor event to mark on the plot.
#[derive(Clone, Debug, PartialEq)]
pub struct Marker {
    /// Time, s.
    pub t_s: f64,
    /// What happened, e.g. `alarm internal`, `sensor fault p_rod`.
    pub label: String,
}

impl Marker {
    /// The replay's alarm, sensor and data-gap events as markers, labelled
    /// with the replay's own names (`alarm internal`, `sensor fault p_rod`).
    /// Filter resets are in the event list but would only clutter the plot.
    pub fn from_events(events: &[EventRecord]) -> Vec<Marker> {
        events
            .iter()
            .filter(|e| e.kind != "filter_reset")
            .map(|e| {
                let what = e.kind.replace('_', " ");
                Marker {
                    t_s: e.t,
                    label: match e.verdict.or(e.sensor) {
                        Some(detail) => format!("{what} {detail}"),
                        None => what,
                    },
                }
            })
            .collect()
    }
}

/// Collects the plotted series while a replay runs (the events come from
/// the replay's summary).
#[derive(Clone, Debug)]
pub struct PlotObserver {
    /// The decimated series.
    pub series: Decimator,
}

impl PlotObserver {
    /// An observer keeping about `max_points` points.
    pub fn new(max_points: usize) -> Self {
        Self {
            series: Decimator::new(max_points),
        }
    }
}

fn or_nan(v: Option<f32>) -> f32 {
    v.unwrap_or(f32::NAN)
}

impl Observer for PlotObserver {
    fn observe(&mut self, s: &Sample, st: &Status) -> std::io::Result<()> {
        self.series.push(Point {
            t_s: s.t_s,
            p_bar: [s.p_supply_bar, s.p_piston_bar, s.p_rod_bar, s.p_tank_bar].map(or_nan),
            x_mm: or_nan(s.x_piston_m) * 1e3,
            u_pct: or_nan(s.u_valve) * 100.0,
            leak_lpm: [or_nan(st.leak_internal_lpm), or_nan(st.leak_external_lpm)],
            detect_lpm: [
                or_nan(st.detect_internal_lpm),
                or_nan(st.detect_external_lpm),
            ],
            probability: st.evidence.map(|e| e.probability),
            evidence_weight: st.evidence_weight,
        });
        Ok(())
    }
}

/// Why a plot could not be drawn.
#[derive(Debug, thiserror::Error)]
pub enum PlotError {
    /// The recording had no samples.
    #[error("{0}: no samples to plot")]
    Empty(String),
    /// The drawing backend failed (e.g. the file cannot be written).
    #[error("{file}: {message}")]
    Draw {
        /// The output file.
        file: String,
        /// What the backend said.
        message: String,
    },
}

/// Range of the finite values, widened so a flat line is still visible.
fn range(values: impl Iterator<Item = f32>, floor: Option<(f32, f32)>) -> (f32, f32) {
    let (mut lo, mut hi) = floor.unwrap_or((f32::INFINITY, f32::NEG_INFINITY));
    for v in values.filter(|v| v.is_finite()) {
        lo = lo.min(v);
        hi = hi.max(v);
    }
    if !lo.is_finite() || !hi.is_finite() {
        return (0.0, 1.0);
    }
    let pad = ((hi - lo) * 0.05).max(1e-3);
    (lo - pad, hi + pad)
}

/// Runs of consecutive finite points of one series, so gaps stay gaps.
fn runs<'a>(
    pts: &'a [Point],
    f: impl Fn(&Point) -> f32 + 'a,
) -> impl Iterator<Item = Vec<(f64, f32)>> + 'a {
    let mut i = 0;
    std::iter::from_fn(move || {
        while i < pts.len() && !f(&pts[i]).is_finite() {
            i += 1;
        }
        if i >= pts.len() {
            return None;
        }
        let mut run = Vec::new();
        while i < pts.len() && f(&pts[i]).is_finite() {
            run.push((pts[i].t_s, f(&pts[i])));
            i += 1;
        }
        Some(run)
    })
}

/// Markers closer than `min_gap_s` share one label, so labels of alarms
/// raised in quick succession (internal, then both) do not overprint.
fn marker_labels(markers: &[Marker], min_gap_s: f64) -> Vec<(f64, String)> {
    let mut out: Vec<(f64, String)> = Vec::new();
    for m in markers {
        match out.last_mut() {
            Some((t, label)) if m.t_s - *t < min_gap_s => {
                label.push_str(", ");
                label.push_str(&m.label);
            }
            _ => out.push((m.t_s, m.label.clone())),
        }
    }
    out
}

type Area<'a> = DrawingArea<SVGBackend<'a>, Shift>;

/// One curve: legend label, colour, and the value it plots.
type Series<'a> = (&'a str, RGBColor, &'a dyn Fn(&Point) -> f32);

/// Draw `series` (label, colour, value) on one panel with a legend, the
/// markers as vertical lines, and optional horizontal reference lines.
#[allow(clippy::too_many_arguments)]
fn panel(
    area: &Area,
    title: &str,
    y_label: &str,
    t: (f64, f64),
    y: (f32, f32),
    pts: &[Point],
    series: &[Series],
    levels: &[(&str, RGBColor, f32)],
    markers: &[Marker],
    label_markers: bool,
    warm_up_end: Option<f64>,
) -> Result<(), String> {
    let e = |e: &dyn std::fmt::Display| e.to_string();
    let mut chart = ChartBuilder::on(area)
        .caption(title, ("sans-serif", 16))
        .margin(8)
        .x_label_area_size(28)
        .y_label_area_size(56)
        .build_cartesian_2d(t.0..t.1, y.0..y.1)
        .map_err(|x| e(&x))?;
    chart
        .configure_mesh()
        .x_desc("t, s")
        .y_desc(y_label)
        .light_line_style(WHITE.mix(0.0))
        .draw()
        .map_err(|x| e(&x))?;
    if let Some(end) = warm_up_end {
        chart
            .draw_series(std::iter::once(Rectangle::new(
                [(t.0, y.0), (end, y.1)],
                GREY.mix(0.12).filled(),
            )))
            .map_err(|x| e(&x))?;
        chart
            .draw_series(std::iter::once(Text::new(
                "warm-up: no evidence yet",
                (t.0 + 0.01 * (t.1 - t.0), y.0 + 0.1 * (y.1 - y.0)),
                ("sans-serif", 12).into_font().color(&GREY),
            )))
            .map_err(|x| e(&x))?;
    }
    for m in markers {
        let colour = if m.label.starts_with("alarm") {
            RED
        } else {
            MAGENTA
        };
        chart
            .draw_series(std::iter::once(PathElement::new(
                vec![(m.t_s, y.0), (m.t_s, y.1)],
                colour.mix(0.6).stroke_width(1),
            )))
            .map_err(|x| e(&x))?;
    }
    if label_markers {
        for (t_s, label) in marker_labels(markers, 0.03 * (t.1 - t.0)) {
            chart
                .draw_series(std::iter::once(Text::new(
                    label,
                    (t_s + 0.003 * (t.1 - t.0), y.1 - 0.04 * (y.1 - y.0)),
                    ("sans-serif", 12).into_font().color(&RED),
                )))
                .map_err(|x| e(&x))?;
        }
    }
    for &(label, colour, level) in levels {
        chart
            .draw_series(std::iter::once(PathElement::new(
                vec![(t.0, level), (t.1, level)],
                colour.stroke_width(1),
            )))
            .map_err(|x| e(&x))?
            .label(label)
            .legend(move |(x, y)| PathElement::new(vec![(x, y), (x + 16, y)], colour));
    }
    for &(label, colour, f) in series {
        let mut first = true;
        for run in runs(pts, f) {
            let s = chart
                .draw_series(LineSeries::new(run, colour.stroke_width(1)))
                .map_err(|x| e(&x))?;
            if first {
                s.label(label)
                    .legend(move |(x, y)| PathElement::new(vec![(x, y), (x + 16, y)], colour));
                first = false;
            }
        }
    }
    chart
        .configure_series_labels()
        .position(SeriesLabelPosition::UpperLeft)
        .background_style(WHITE.mix(0.8))
        .border_style(BLACK.mix(0.3))
        .draw()
        .map_err(|x| e(&x))?;
    Ok(())
}

const ORANGE: RGBColor = RGBColor(230, 120, 0);
const GREY: RGBColor = RGBColor(150, 150, 150);
const GREEN_D: RGBColor = RGBColor(0, 140, 60);
const LIGHT_BLUE: RGBColor = RGBColor(150, 170, 255);
const LIGHT_ORANGE: RGBColor = RGBColor(250, 200, 140);

/// Write the plot of one replayed recording to `out` (SVG).
pub fn write_svg(
    out: &Path,
    summary: &ReplaySummary,
    observer: &PlotObserver,
    params: &Params,
) -> Result<(), PlotError> {
    let pts = observer.series.points();
    let (Some(first), Some(last)) = (pts.first(), pts.last()) else {
        return Err(PlotError::Empty(summary.recording.clone()));
    };
    let t = (first.t_s, last.t_s.max(first.t_s + 1e-3));
    let file = out.display().to_string();
    let draw = |message: String| PlotError::Draw {
        file: file.clone(),
        message,
    };
    let root = SVGBackend::new(out, (1200, 1150)).into_drawing_area();
    root.fill(&WHITE).map_err(|e| draw(e.to_string()))?;
    let alarm = params.alarm.alarm_lpm as f32;
    let warning = params.alarm.warning_lpm as f32;
    let heading = format!(
        "{}: verdict {}{}; leak internal {} l/min, external {} l/min",
        summary.recording,
        summary.verdict,
        summary
            .first_alarm_s
            .map_or(String::new(), |t| format!(", first alarm at {t:.3} s")),
        summary
            .leak_internal_lpm
            .map_or("–".into(), |v| format!("{v:.3}")),
        summary
            .leak_external_lpm
            .map_or("–".into(), |v| format!("{v:.3}")),
    );
    let root = root
        .titled(&heading, ("sans-serif", 18))
        .map_err(|e| draw(e.to_string()))?;
    let areas = root.split_evenly((5, 1));
    let m = &Marker::from_events(&summary.events);
    // Until the filters have warmed up there are no estimates to show.
    let warm_up_end = pts
        .iter()
        .find(|p| p.leak_lpm[0].is_finite())
        .map_or(Some(t.1), |p| (p.t_s > t.0).then_some(p.t_s));
    let p_range = range(pts.iter().flat_map(|p| p.p_bar), Some((0.0, 1.0)));
    panel(
        &areas[0],
        "Pressures",
        "bar",
        t,
        p_range,
        pts,
        &[
            ("supply", BLACK, &|p: &Point| p.p_bar[0]),
            ("piston chamber", BLUE, &|p: &Point| p.p_bar[1]),
            ("rod chamber", ORANGE, &|p: &Point| p.p_bar[2]),
            ("tank", GREY, &|p: &Point| p.p_bar[3]),
        ],
        &[],
        m,
        false,
        None,
    )
    .map_err(draw)?;
    panel(
        &areas[1],
        "Piston position",
        "mm",
        t,
        range(pts.iter().map(|p| p.x_mm), None),
        pts,
        &[("position", BLUE, &|p: &Point| p.x_mm)],
        &[],
        m,
        false,
        None,
    )
    .map_err(draw)?;
    panel(
        &areas[2],
        "Valve command",
        "% of full scale",
        t,
        range(pts.iter().map(|p| p.u_pct), Some((-5.0, 5.0))),
        pts,
        &[("command", BLACK, &|p: &Point| p.u_pct)],
        &[],
        m,
        false,
        None,
    )
    .map_err(draw)?;
    let leak_range = range(
        pts.iter()
            .flat_map(|p| p.leak_lpm.into_iter().chain(p.detect_lpm)),
        Some((-0.05, 1.5 * alarm)),
    );
    panel(
        &areas[3],
        "Leak flow estimates",
        "l/min",
        t,
        leak_range,
        pts,
        &[
            ("internal (detection window)", LIGHT_BLUE, &|p: &Point| {
                p.detect_lpm[0]
            }),
            ("external (detection window)", LIGHT_ORANGE, &|p: &Point| {
                p.detect_lpm[1]
            }),
            ("internal", BLUE, &|p: &Point| p.leak_lpm[0]),
            ("external", ORANGE, &|p: &Point| p.leak_lpm[1]),
        ],
        &[
            ("alarm level", RED, alarm),
            ("warning level", MAGENTA, warning),
        ],
        m,
        true,
        warm_up_end,
    )
    .map_err(draw)?;
    panel(
        &areas[4],
        "Hypothesis probabilities and evidence weight",
        "probability",
        t,
        (-0.02, 1.02),
        pts,
        &[
            ("healthy", GREEN_D, &|p: &Point| p.probability[0]),
            ("internal", BLUE, &|p: &Point| p.probability[1]),
            ("external", ORANGE, &|p: &Point| p.probability[2]),
            ("both", RED, &|p: &Point| p.probability[3]),
            ("evidence weight", GREY, &|p: &Point| p.evidence_weight),
        ],
        &[],
        m,
        false,
        warm_up_end,
    )
    .map_err(draw)?;
    root.present().map_err(|e| draw(e.to_string()))?;
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    fn point(t: f64) -> Point {
        Point {
            t_s: t,
            p_bar: [50.0, 20.0, 25.0, 1.0],
            x_mm: 100.0,
            u_pct: 0.0,
            leak_lpm: [f32::NAN; 2],
            detect_lpm: [f32::NAN; 2],
            probability: [0.25; 4],
            evidence_weight: 1.0,
        }
    }

    #[test]
    fn decimation_is_bounded_ordered_and_even() {
        let mut d = Decimator::new(100);
        for k in 0..100_000 {
            d.push(point(k as f64 * 1e-3));
        }
        let p = d.points();
        assert!(p.len() >= 100 && p.len() < 200, "{} points", p.len());
        assert_eq!(p[0].t_s, 0.0);
        let step = p[1].t_s - p[0].t_s;
        for w in p.windows(2) {
            assert!((w[1].t_s - w[0].t_s - step).abs() < 1e-9, "uneven stride");
        }
        // The last kept point is within one stride of the stream's end.
        assert!(99.999 - p.last().unwrap().t_s <= step + 1e-9);
    }

    #[test]
    fn short_streams_are_kept_whole() {
        let mut d = Decimator::new(100);
        for k in 0..150 {
            d.push(point(k as f64));
        }
        assert_eq!(d.points().len(), 150);
    }

    #[test]
    fn gaps_split_a_series() {
        let mut pts: Vec<Point> = (0..10).map(|k| point(k as f64)).collect();
        pts[4].x_mm = f32::NAN;
        pts[5].x_mm = f32::NAN;
        let r: Vec<_> = runs(&pts, |p| p.x_mm).collect();
        assert_eq!(r.len(), 2);
        assert_eq!((r[0].len(), r[1].len()), (4, 4));
    }

    #[test]
    fn close_markers_share_a_label() {
        let m = |t_s: f64, label: &str| Marker {
            t_s,
            label: label.into(),
        };
        let l = marker_labels(
            &[
                m(12.726, "alarm internal"),
                m(12.732, "alarm both"),
                m(30.0, "alarm cleared"),
            ],
            0.5,
        );
        assert_eq!(
            l,
            vec![
                (12.726, "alarm internal, alarm both".to_string()),
                (30.0, "alarm cleared".to_string())
            ]
        );
    }

    #[test]
    fn ranges_ignore_non_finite_values() {
        let (lo, hi) = range([1.0, f32::NAN, 3.0, f32::INFINITY].into_iter(), None);
        assert!(lo < 1.0 && lo > 0.8 && hi > 3.0 && hi < 3.2);
        assert_eq!(range([f32::NAN].into_iter(), None), (0.0, 1.0));
    }
}
