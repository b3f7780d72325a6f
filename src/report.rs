//! Comparing runs: a side-by-side table of their test metrics (like the paper's
//! Figure 2), a PNG bar chart of the five metrics with 95 % intervals, and learning
//! curves from their evaluations.

use crate::config::{ConfigFileError, RunConfig};
use crate::metrics::{Estimate, TestMetrics};
use plotters::prelude::*;
use std::path::{Path, PathBuf};

/// A run's results, read from its directory.
#[derive(Clone, Debug)]
pub struct RunResults {
    /// Label: the directory's name.
    pub name: String,
    /// The algorithm trained.
    pub algo: String,
    /// `test/metrics.json`.
    pub metrics: TestMetrics,
    /// `evaluations.csv` as `(env_step, mean_return, score_rate)` rows.
    pub evaluations: Vec<(u64, f64, f64)>,
}

/// A run directory that cannot be reported on, or a report file that could not be
/// written; names the file.
#[derive(Debug, thiserror::Error)]
pub enum ReportError {
    /// The run's configuration is missing or unreadable.
    #[error(transparent)]
    Config(#[from] ConfigFileError),
    /// Another file could not be read or written.
    #[error("{path}: {message}")]
    File {
        /// The file at fault.
        path: PathBuf,
        /// What went wrong.
        message: String,
    },
}

fn error(path: &Path, message: impl ToString) -> ReportError {
    ReportError::File {
        path: path.to_path_buf(),
        message: message.to_string(),
    }
}

impl RunResults {
    /// Reads the run in `dir` (it must have finished its test).
    pub fn read(dir: &Path) -> Result<Self, ReportError> {
        let config = RunConfig::load_run(dir)?;
        let path = dir.join("test/metrics.json");
        let text = std::fs::read_to_string(&path)
            .map_err(|e| error(&path, format!("{e} (has the run finished its test?)")))?;
        let metrics = serde_json::from_str(&text).map_err(|e| error(&path, e))?;
        let path = dir.join("evaluations.csv");
        let text = std::fs::read_to_string(&path).unwrap_or_default();
        let evaluations = text
            .lines()
            .skip(1)
            .enumerate()
            .map(|(i, line)| {
                let cols: Vec<&str> = line.split(',').collect();
                let bad = || error(&path, format!("line {}: not a number", i + 2));
                let num = |k: usize| cols.get(k).and_then(|v| v.parse::<f64>().ok());
                let step = cols.first().and_then(|v| v.parse::<u64>().ok());
                Ok((
                    step.ok_or_else(bad)?,
                    num(1).ok_or_else(bad)?,
                    num(2).ok_or_else(bad)?,
                ))
            })
            .collect::<Result<_, ReportError>>()?;
        let name = dir
            .canonicalize()
            .ok()
            .and_then(|d| d.file_name().map(|n| n.to_string_lossy().to_string()))
            .unwrap_or_else(|| dir.display().to_string());
        Ok(Self {
            name,
            algo: config.algo.to_string(),
            metrics,
            evaluations,
        })
    }
}

/// The runs' metrics side by side: a row per metric, a column per run, each cell
/// `mean [low, high]`.
pub fn markdown_table(runs: &[RunResults]) -> String {
    let mut out = String::from("| metric |");
    for r in runs {
        out += &format!(" {} ({}, {} ep.) |", r.name, r.algo, r.metrics.episodes);
    }
    out += "\n| --- |";
    out += &" --- |".repeat(runs.len());
    out.push('\n');
    let rows = |r: &RunResults| r.metrics.rows();
    for (k, (metric, _)) in runs[0].metrics.rows().iter().enumerate() {
        out += &format!("| {metric} |");
        for r in runs {
            let e = rows(r)[k].1;
            out += &format!(" {:.3} [{:.3}, {:.3}] |", e.mean, e.ci95[0], e.ci95[1]);
        }
        out.push('\n');
    }
    out
}

/// Registers the bundled DejaVu Sans for chart text (once per process).
fn register_font() {
    static ONCE: std::sync::Once = std::sync::Once::new();
    ONCE.call_once(|| {
        plotters::style::register_font("sans-serif", FontStyle::Normal, dejavu::sans::regular())
            .map_err(|_| ())
            .expect("DejaVu Sans is a valid font");
    });
}

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

type Drawing<'a> = DrawingArea<BitMapBackend<'a>, plotters::coord::Shift>;
type DrawError =
    DrawingAreaErrorKind<<BitMapBackend<'static> as plotters::backend::DrawingBackend>::ErrorType>;

/// Draws a PNG of `size` pixels with `draw` into a temporary file renamed to `path`.
fn png(
    path: &Path,
    size: (u32, u32),
    draw: impl FnOnce(&Drawing<'_>) -> Result<(), DrawError>,
) -> Result<(), ReportError> {
    register_font();
    let tmp = path.with_extension("tmp.png");
    {
        let root = BitMapBackend::new(&tmp, size).into_drawing_area();
        root.fill(&WHITE)
            .and_then(|()| draw(&root))
            .and_then(|()| root.present())
            .map_err(|e| error(path, e))?;
    }
    std::fs::rename(&tmp, path).map_err(|e| error(path, e))
}

/// Writes a PNG bar chart of the five paper metrics (one panel each, a bar per run with
/// its 95 % interval) to `path`.
pub fn metrics_chart(runs: &[RunResults], path: &Path) -> Result<(), ReportError> {
    png(path, (1500, 360), |root| {
        for (k, panel) in root.split_evenly((1, 5)).iter().enumerate() {
            let (title, _) = runs[0].metrics.rows()[k];
            let estimates: Vec<Estimate> = runs.iter().map(|r| r.metrics.rows()[k].1).collect();
            bar_panel(panel, title, &estimates)?;
        }
        Ok(())
    })
}

fn bar_panel(area: &Drawing<'_>, title: &str, estimates: &[Estimate]) -> Result<(), DrawError> {
    let top = estimates
        .iter()
        .map(|e| e.ci95[1].max(e.mean))
        .fold(0.0f64, f64::max);
    let bottom = estimates
        .iter()
        .map(|e| e.ci95[0].min(e.mean))
        .fold(0.0f64, f64::min);
    let top = if top - bottom < 1e-12 {
        bottom + 1.0
    } else {
        top
    };
    let pad = 0.1 * (top - bottom);
    let n = estimates.len();
    let mut chart = ChartBuilder::on(area)
        .caption(title, ("sans-serif", 16))
        .margin(8)
        .x_label_area_size(10)
        .y_label_area_size(55)
        .build_cartesian_2d(0.0..n as f64, (bottom - pad).min(0.0)..top + pad)?;
    chart
        .configure_mesh()
        .disable_x_mesh()
        .disable_x_axis()
        .y_labels(6)
        .y_label_formatter(&|v| tick(*v, top - bottom))
        .label_style(("sans-serif", 12))
        .draw()?;
    for (i, e) in estimates.iter().enumerate() {
        let x = i as f64;
        let c = colour(i);
        chart.draw_series([Rectangle::new(
            [(x + 0.15, 0.0), (x + 0.85, e.mean)],
            c.filled(),
        )])?;
        chart.draw_series([PathElement::new(
            vec![(x + 0.5, e.ci95[0]), (x + 0.5, e.ci95[1])],
            BLACK.stroke_width(2),
        )])?;
    }
    Ok(())
}

/// Writes a PNG of the runs' learning curves (evaluation mean return and score rate
/// against env steps) with a legend of run names to `path`.
pub fn learning_curves(runs: &[RunResults], path: &Path) -> Result<(), ReportError> {
    type Series = (
        &'static str,
        fn(&(u64, f64, f64)) -> f64,
        Option<(f64, f64)>,
    );
    let series: [Series; 2] = [
        ("evaluation mean return", |e| e.1, None),
        ("evaluation score rate", |e| e.2, Some((0.0, 1.0))),
    ];
    png(path, (1200, 450), |root| {
        for (panel, (title, value, range)) in root.split_evenly((1, 2)).iter().zip(series) {
            curve_panel(panel, title, runs, value, range)?;
        }
        Ok(())
    })
}

fn curve_panel(
    area: &Drawing<'_>,
    title: &str,
    runs: &[RunResults],
    value: fn(&(u64, f64, f64)) -> f64,
    range: Option<(f64, f64)>,
) -> Result<(), DrawError> {
    let points = runs.iter().flat_map(|r| r.evaluations.iter());
    let max_step = points.clone().map(|e| e.0).max().unwrap_or(1).max(1) as f64;
    let (lo, hi) = points
        .map(value)
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
        .x_label_formatter(&|v| format!("{v:.0}"))
        .y_label_formatter(&|v| tick(*v, hi - lo + 2.0 * pad))
        .label_style(("sans-serif", 12))
        .draw()?;
    for (i, r) in runs.iter().enumerate() {
        let c = colour(i);
        chart
            .draw_series(LineSeries::new(
                r.evaluations.iter().map(|e| (e.0 as f64, value(e))),
                c.stroke_width(2),
            ))?
            .label(format!("{} ({})", r.name, r.algo))
            .legend(move |(x, y)| PathElement::new(vec![(x, y), (x + 20, y)], c.stroke_width(2)));
        chart.draw_series(
            r.evaluations
                .iter()
                .map(|e| Circle::new((e.0 as f64, value(e)), 3, c.filled())),
        )?;
    }
    chart
        .configure_series_labels()
        .position(SeriesLabelPosition::UpperLeft)
        .background_style(WHITE.mix(0.8))
        .border_style(BLACK)
        .label_font(("sans-serif", 12))
        .draw()?;
    Ok(())
}

/// Writes `report.md` (table and legend of colours), `metrics.png`, `curves.png` and
/// `report.json` (every run's metrics) into `out`; returns the markdown.
pub fn write_report(runs: &[RunResults], out: &Path) -> Result<String, ReportError> {
    assert!(!runs.is_empty(), "a report needs at least one run");
    std::fs::create_dir_all(out).map_err(|e| error(out, e))?;
    metrics_chart(runs, &out.join("metrics.png"))?;
    learning_curves(runs, &out.join("curves.png"))?;
    let mut md = String::from("# Test metrics (mean [95 % interval])\n\n");
    md += &markdown_table(runs);
    md += "\n![test metrics](metrics.png)\n\nBars in column order: ";
    md += &runs
        .iter()
        .map(|r| r.name.as_str())
        .collect::<Vec<_>>()
        .join(", ");
    md += ".\n\n![learning curves](curves.png)\n";
    let json: Vec<serde_json::Value> = runs
        .iter()
        .map(|r| serde_json::json!({"run": r.name, "algo": r.algo, "metrics": r.metrics}))
        .collect();
    let json = serde_json::to_string_pretty(&json).expect("metrics serialise");
    crate::run_dir::write_atomic(&out.join("report.json"), json.as_bytes())
        .map_err(|e| error(&e.path, e.source))?;
    crate::run_dir::write_atomic(&out.join("report.md"), md.as_bytes())
        .map_err(|e| error(&e.path, e.source))?;
    Ok(md)
}
