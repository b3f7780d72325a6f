//! The report's PNG charts, each readable alone: a bar per group for each test metric
//! (mean over seeds, 95 % interval, a dot per seed, the unit on the axis, the paper's
//! figure as a dashed line, a legend naming every group), and learning curves (mean over
//! seeds with a 95 % band, env steps on the x axis).

use super::claims::{PAPER_FINAL_DISTANCE, PAPER_OTHERS_SCORE_RATE_BELOW, PAPER_SAC_SCORE_RATE};
use super::stats::{self, mean};
use super::{EvalPoint, Group, ReportError, error};
use crate::play::metrics::Estimate;
use crate::png::{DrawError, Drawing};
use plotters::coord::types::RangedCoordf64;
use plotters::prelude::*;
use plotters::style::text_anchor::{HPos, Pos, VPos};
use std::path::Path;

/// An axis label with as many decimals as an axis spanning `span` needs.
fn tick(v: f64, span: f64) -> String {
    let decimals = if span >= 100.0 {
        0
    } else if span >= 1.0 {
        2
    } else {
        3
    };
    format!("{v:.decimals$}")
}

/// One colour per run.
fn colour(i: usize) -> RGBColor {
    let (r, g, b) = Palette99::pick(i).to_rgba().rgb();
    RGBColor(r, g, b)
}

/// Draws a PNG of `size` pixels with `draw` into `path`, atomically.
fn png(
    path: &Path,
    size: (u32, u32),
    draw: impl FnOnce(&Drawing<'_>) -> Result<(), DrawError>,
) -> Result<(), ReportError> {
    crate::png::png(path, size, draw).map_err(|e| error(path, e))
}

/// A reference line drawn across a panel: the paper's figure and its label.
type PaperLine = (f64, String);

/// The paper's figures for metric `k` of [`crate::play::metrics::TestMetrics::rows`]
/// (score rate, final distance), as lines to draw.
fn paper_lines(k: usize) -> Vec<PaperLine> {
    match k {
        0 => vec![
            (PAPER_SAC_SCORE_RATE, "paper SAC 42.9 %".into()),
            (
                PAPER_OTHERS_SCORE_RATE_BELOW,
                "paper PPO, TD3 below 21.5 %".into(),
            ),
        ],
        4 => PAPER_FINAL_DISTANCE
            .iter()
            .map(|(algo, v)| (*v, format!("paper {} {v} cm", algo.to_uppercase())))
            .collect(),
        _ => Vec::new(),
    }
}

/// The y-axis description of a metric named like `mean ball speed (cm/s)`: its unit.
fn unit(metric: &str) -> &str {
    match metric.split_once('(') {
        Some((_, rest)) => rest.trim_end_matches(')'),
        None if metric == "score rate" => "share of episodes that scored",
        None => "reward summed over an episode",
    }
}

/// Height in pixels of the legend strip under the metric panels.
const LEGEND_HEIGHT: u32 = 40;

/// Writes a PNG bar chart of the five paper metrics (one panel each, its unit on the y
/// axis; a bar per group with its 95 % interval and a dot per seed; the paper's figures as
/// dashed lines) to `path`, with a legend naming each group's colour.
pub fn metrics_chart(groups: &[Group], path: &Path) -> Result<(), ReportError> {
    let summaries: Vec<_> = groups.iter().map(Group::summaries).collect();
    let labels: Vec<String> = groups
        .iter()
        .map(|g| {
            let n = g.runs.len();
            match n {
                1 => g.label.clone(),
                _ => format!("{} ({n} seeds)", g.label),
            }
        })
        .collect();
    png(path, (1500, 400 + LEGEND_HEIGHT), |root| {
        let (charts, legend) = root.split_vertically(400);
        for (k, panel) in charts.split_evenly((1, 5)).iter().enumerate() {
            let title = summaries[0][k].metric;
            let bars: Vec<(Estimate, &[f64])> = summaries
                .iter()
                .map(|s| (s[k].mean, s[k].per_seed.as_slice()))
                .collect();
            bar_panel(panel, title, &bars, &paper_lines(k))?;
        }
        legend_strip(&legend, &labels)
    })
}

/// A row of colour swatches with the group names, in bar order.
fn legend_strip(area: &Drawing<'_>, labels: &[String]) -> Result<(), DrawError> {
    let style: TextStyle = ("sans-serif", 14).into_font().into();
    let mut x = 70;
    for (i, label) in labels.iter().enumerate() {
        let y = (LEGEND_HEIGHT / 2) as i32;
        area.draw(&Rectangle::new(
            [(x, y - 7), (x + 14, y + 7)],
            colour(i).mix(0.6).filled(),
        ))?;
        area.draw(&Text::new(label.as_str(), (x + 20, y - 8), style.clone()))?;
        let (w, _) = area.estimate_text_size(label, &style)?;
        x += 20 + w as i32 + 30;
    }
    Ok(())
}

fn bar_panel(
    area: &Drawing<'_>,
    title: &str,
    bars: &[(Estimate, &[f64])],
    paper: &[PaperLine],
) -> Result<(), DrawError> {
    let values = bars
        .iter()
        .flat_map(|(e, seeds)| {
            [e.mean, e.ci95[0], e.ci95[1]]
                .into_iter()
                .chain(seeds.iter().copied())
        })
        .chain(paper.iter().map(|p| p.0))
        .filter(|v| v.is_finite());
    let (bottom, top) = values.fold((0.0f64, 0.0f64), |(lo, hi), v| (lo.min(v), hi.max(v)));
    let top = if top - bottom < 1e-12 {
        bottom + 1.0
    } else {
        top
    };
    let pad = 0.1 * (top - bottom);
    let n = bars.len();
    let mut chart = ChartBuilder::on(area)
        .caption(title, ("sans-serif", 16))
        .margin(8)
        .x_label_area_size(10)
        .y_label_area_size(65)
        .build_cartesian_2d(0.0..n as f64, (bottom - pad).min(0.0)..top + pad)?;
    chart
        .configure_mesh()
        .disable_x_mesh()
        .disable_x_axis()
        .y_desc(unit(title))
        .y_labels(6)
        .y_label_formatter(&|v| tick(*v, top - bottom))
        .label_style(("sans-serif", 12))
        .draw()?;
    for (i, (e, seeds)) in bars.iter().enumerate() {
        let x = i as f64;
        let c = colour(i);
        chart.draw_series([Rectangle::new(
            [(x + 0.15, 0.0), (x + 0.85, e.mean)],
            c.mix(0.6).filled(),
        )])?;
        chart.draw_series([PathElement::new(
            vec![(x + 0.5, e.ci95[0]), (x + 0.5, e.ci95[1])],
            BLACK.stroke_width(2),
        )])?;
        if seeds.len() > 1 {
            let k = seeds.len() as f64;
            chart.draw_series(seeds.iter().enumerate().map(|(j, v)| {
                Circle::new(
                    (x + 0.3 + 0.4 * j as f64 / (k - 1.0), *v),
                    3,
                    BLACK.filled(),
                )
            }))?;
        }
    }
    draw_paper_lines(&mut chart, paper, n as f64)
}

/// The paper's figures as dashed red lines across `0..width`, each labelled above its
/// left end.
fn draw_paper_lines(
    chart: &mut ChartContext<'_, BitMapBackend<'_>, Cartesian2d<RangedCoordf64, RangedCoordf64>>,
    paper: &[PaperLine],
    width: f64,
) -> Result<(), DrawError> {
    for (v, label) in paper {
        chart.draw_series(DashedLineSeries::new(
            [(0.0, *v), (width, *v)],
            6,
            4,
            RED.stroke_width(2),
        ))?;
        chart.draw_series([Text::new(
            label.clone(),
            (0.02 * width, *v),
            ("sans-serif", 12)
                .into_font()
                .color(&RED)
                .pos(Pos::new(HPos::Left, VPos::Bottom)),
        )])?;
    }
    Ok(())
}

/// A point of a band: `(env step, mean, low, high)`.
type BandPoint = (f64, f64, f64, f64);

/// A labelled curve with its band.
type Band = (String, Vec<BandPoint>);

/// The mean over a group's seeds of an evaluation value at each env step that every seed
/// evaluated, with its 95 % bootstrap band.
fn band(group: &Group, value: fn(&EvalPoint) -> f64) -> Vec<BandPoint> {
    let first = &group.runs[0].evaluations;
    first
        .iter()
        .enumerate()
        .filter_map(|(i, p)| {
            let at: Vec<f64> = group
                .runs
                .iter()
                .map(|r| r.evaluations.get(i).filter(|q| q.0 == p.0).map(value))
                .collect::<Option<_>>()?;
            let e = if at.len() > 1 {
                stats::over_seeds(&at, mean)
            } else {
                Estimate {
                    mean: at[0],
                    ci95: [at[0], at[0]],
                }
            };
            Some((p.0 as f64, e.mean, e.ci95[0], e.ci95[1]))
        })
        .collect()
}

/// Writes a PNG of the learner groups' learning curves (evaluation mean return and score
/// rate against env steps: mean over seeds with a 95 % band) to `path`.
pub fn learning_curves(groups: &[Group], path: &Path) -> Result<(), ReportError> {
    type Series = (
        &'static str,
        &'static str,
        fn(&EvalPoint) -> f64,
        Option<(f64, f64)>,
        Vec<PaperLine>,
    );
    let series: [Series; 2] = [
        (
            "evaluation mean return",
            "return per episode",
            |e| e.1,
            None,
            Vec::new(),
        ),
        (
            "evaluation score rate",
            "share of episodes that scored",
            |e| e.2,
            Some((0.0, 1.0)),
            paper_lines(0),
        ),
    ];
    let learners: Vec<&Group> = groups.iter().filter(|g| !g.runs[0].is_baseline()).collect();
    png(path, (1200, 450), |root| {
        for (panel, (title, y_desc, value, range, paper)) in
            root.split_evenly((1, 2)).iter().zip(series)
        {
            let bands: Vec<Band> = learners
                .iter()
                .map(|g| {
                    let n = g.runs.len();
                    let seeds = if n == 1 { "seed" } else { "seeds" };
                    (format!("{} ({n} {seeds})", g.label), band(g, value))
                })
                .collect();
            curve_panel(panel, (title, y_desc), &bands, range, &paper)?;
        }
        Ok(())
    })
}

fn curve_panel(
    area: &Drawing<'_>,
    (title, y_desc): (&str, &str),
    bands: &[Band],
    range: Option<(f64, f64)>,
    paper: &[PaperLine],
) -> Result<(), DrawError> {
    let points = bands.iter().flat_map(|(_, b)| b.iter());
    let max_step = points.clone().map(|p| p.0).fold(1.0, f64::max);
    let (lo, hi) = points
        .flat_map(|p| [p.2, p.3])
        .fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), v| {
            (lo.min(v), hi.max(v))
        });
    let (lo, hi) = match range {
        Some(fixed) => fixed,
        None if lo.is_finite() => (lo, hi),
        None => (0.0, 1.0),
    };
    let pad = (0.05 * (hi - lo)).max(0.05 * hi.abs()).max(1e-3);
    let mut chart = ChartBuilder::on(area)
        .caption(title, ("sans-serif", 18))
        .margin(10)
        .x_label_area_size(35)
        .y_label_area_size(60)
        .build_cartesian_2d(0.0..max_step, lo - pad..hi + pad)?;
    chart
        .configure_mesh()
        .x_desc("env steps")
        .y_desc(y_desc)
        .x_label_formatter(&|v| format!("{v:.0}"))
        .y_label_formatter(&|v| tick(*v, hi - lo + 2.0 * pad))
        .label_style(("sans-serif", 12))
        .draw()?;
    for (i, (label, band)) in bands.iter().enumerate() {
        let c = colour(i);
        let outline: Vec<(f64, f64)> = band
            .iter()
            .map(|p| (p.0, p.3))
            .chain(band.iter().rev().map(|p| (p.0, p.2)))
            .collect();
        chart.draw_series([Polygon::new(outline, c.mix(0.2).filled())])?;
        chart
            .draw_series(LineSeries::new(
                band.iter().map(|p| (p.0, p.1)),
                c.stroke_width(2),
            ))?
            .label(label.as_str())
            .legend(move |(x, y)| PathElement::new(vec![(x, y), (x + 20, y)], c.stroke_width(2)));
    }
    draw_paper_lines(&mut chart, paper, max_step)?;
    chart
        .configure_series_labels()
        .position(SeriesLabelPosition::UpperLeft)
        .background_style(WHITE.mix(0.8))
        .border_style(BLACK)
        .label_font(("sans-serif", 12))
        .draw()?;
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::play::metrics::TestMetrics;

    #[test]
    fn every_metric_panel_names_its_unit_and_the_papers_figures() {
        let one = crate::play::metrics::EpisodeSummary {
            steps: 1,
            ..Default::default()
        };
        let names = TestMetrics::from_episodes(&[one])
            .rows()
            .map(|(name, _)| name);
        let units: Vec<&str> = names.iter().map(|n| unit(n)).collect();
        assert_eq!(
            units[..5],
            [
                "share of episodes that scored",
                "cm",
                "cm/s",
                "reward summed over an episode",
                "cm"
            ]
        );
        let score: Vec<f64> = paper_lines(0).iter().map(|l| l.0).collect();
        assert_eq!(score, [0.429, 0.215]);
        let distance: Vec<String> = paper_lines(4).into_iter().map(|l| l.1).collect();
        assert_eq!(distance, ["paper SAC 24.87 cm", "paper TD3 31.92 cm"]);
        assert!((1..4).all(|k| paper_lines(k).is_empty()));
    }
}
