//! How the reconstruction scales with the basis: the oracle's and one view's error against
//! the database's size (at the default K) and against K (at the default size), with what a
//! 500-pixel dab and the full table cost at each K, so that the defaults are chosen by
//! measurement. Each point is one lean [`run_bench`] on the quick held-out set.

use super::live::LiveOptions;
use super::{BenchOptions, BenchReport, Paint, run_bench};
use crate::basis::BasisCache;
use crate::error::{Error, Result};
use crate::fs_atomic::write_atomically;
use plotters::prelude::*;
use std::io::Write;
use std::path::Path;

/// What the sweep varies.
#[derive(Clone, Debug)]
pub struct ScalingOptions {
    /// Database sizes tried at `default_components`.
    pub sizes: Vec<usize>,
    /// K values tried at `default_size`.
    pub components: Vec<usize>,
    pub default_size: usize,
    pub default_components: usize,
    /// The bench every point runs, narrowed to one view, HDR paint and the oracle.
    pub base: BenchOptions,
}

impl ScalingOptions {
    /// Sizes 100 to 2,000 and K 10 to 40 around the defaults, on the quick held-out set.
    pub fn standard(cache: BasisCache) -> Self {
        Self {
            sizes: vec![100, 300, 1000, 2000],
            components: vec![10, 20, 30, 40],
            default_size: crate::materials::database::DatabaseSpec::default().size,
            default_components: crate::basis::BasisSpec::DEFAULT_COMPONENTS,
            base: BenchOptions::quick(cache),
        }
    }

    /// Every (materials, K) the sweep measures, sizes first, each once.
    pub fn points(&self) -> Vec<(usize, usize)> {
        let mut out: Vec<(usize, usize)> = self
            .sizes
            .iter()
            .map(|&s| (s, self.default_components))
            .collect();
        for &k in &self.components {
            let point = (self.default_size, k);
            if !out.contains(&point) {
                out.push(point);
            }
        }
        out
    }

    fn bench_options(&self, materials: usize, components: usize) -> BenchOptions {
        let base = &self.base;
        BenchOptions {
            mode: "scaling",
            cache: base.cache.clone(),
            basis_materials: materials,
            paper: super::Config {
                components,
                views: 1,
                paint: Paint::Hdr,
                ..base.paper
            },
            components: vec![components],
            regularizations: Vec::new(),
            models: Vec::new(),
            view_counts: vec![1],
            resolutions: Vec::new(),
            paints: vec![Paint::Hdr],
            policies: Vec::new(),
            analytic_views: Vec::new(),
            live: LiveOptions {
                dab_pixels: vec![500],
                dab_components: vec![components],
                dab_repeats: base.live.dab_repeats,
                repeats: base.live.repeats,
            },
            error_maps: None,
            next_view: None,
            ..base.clone()
        }
    }
}

/// One point of the sweep.
#[derive(Clone, Debug, PartialEq)]
pub struct ScalingPoint {
    pub materials: usize,
    pub components: usize,
    /// How the basis came (built, loaded, …) and the seconds it took.
    pub basis: String,
    pub basis_seconds: f64,
    pub oracle_mean: f64,
    pub oracle_median: f64,
    pub one_view_mean: f64,
    pub one_view_median: f64,
    pub one_view_log: f64,
    pub dab_p95_ms: f64,
    pub full_table_ms: f64,
}

impl ScalingPoint {
    fn from_report(materials: usize, components: usize, report: &BenchReport) -> Self {
        let figures = report.key_figures();
        let figure = |key: &str| {
            figures
                .iter()
                .find(|(k, _)| *k == key)
                .map_or(f64::NAN, |&(_, v)| v)
        };
        let (basis, basis_seconds) = report
            .bases
            .iter()
            .find(|(k, _, _)| *k == components)
            .map_or((String::new(), f64::NAN), |(_, how, s)| (how.clone(), *s));
        Self {
            materials,
            components,
            basis,
            basis_seconds,
            oracle_mean: figure("rel_rmse_oracle_k20"),
            oracle_median: figure("median_rel_rmse_oracle_k20"),
            one_view_mean: figure("rel_rmse_1view_k20"),
            one_view_median: figure("median_rel_rmse_1view_k20"),
            one_view_log: figure("log_rmse_1view_k20"),
            dab_p95_ms: figure("dab_solve_ms_p95"),
            full_table_ms: figure("full_table_ms"),
        }
    }
}

/// The sweep's results.
#[derive(Clone, Debug)]
pub struct ScalingReport {
    pub points: Vec<ScalingPoint>,
    pub default_size: usize,
    pub default_components: usize,
    pub machine: String,
    pub held_out: usize,
}

/// Runs every point of `options`; bases it lacks are built (and cached).
pub fn run_scaling(options: &ScalingOptions, log: &dyn Fn(&str)) -> Result<ScalingReport> {
    let mut points = Vec::new();
    let mut machine = String::new();
    for (materials, components) in options.points() {
        log(&format!("scaling: {materials} materials, K = {components}"));
        let report = run_bench(&options.bench_options(materials, components), log)?;
        machine = report.machine.describe();
        points.push(ScalingPoint::from_report(materials, components, &report));
    }
    Ok(ScalingReport {
        points,
        default_size: options.default_size,
        default_components: options.default_components,
        machine,
        held_out: options.base.database_materials + options.base.hand_built,
    })
}

impl ScalingReport {
    /// The points along the database size, at the default K, smallest first.
    pub fn by_size(&self) -> Vec<&ScalingPoint> {
        let mut v: Vec<&ScalingPoint> = self
            .points
            .iter()
            .filter(|p| p.components == self.default_components)
            .collect();
        v.sort_by_key(|p| p.materials);
        v
    }

    /// The points along K, at the default size, smallest first.
    pub fn by_components(&self) -> Vec<&ScalingPoint> {
        let mut v: Vec<&ScalingPoint> = self
            .points
            .iter()
            .filter(|p| p.materials == self.default_size)
            .collect();
        v.sort_by_key(|p| p.components);
        v
    }

    pub fn csv(&self) -> String {
        let mut out = String::from(
            "materials,components,basis,basis_seconds,oracle_mean_rel_rmse,oracle_median_rel_rmse,\
             one_view_mean_rel_rmse,one_view_median_rel_rmse,one_view_log_rmse,dab_500_p95_ms,\
             full_table_ms\n",
        );
        for p in &self.points {
            out.push_str(&format!(
                "{},{},{},{:.1},{:.6},{:.6},{:.6},{:.6},{:.6},{:.4},{:.3}\n",
                p.materials,
                p.components,
                p.basis.replace(',', ";"),
                p.basis_seconds,
                p.oracle_mean,
                p.oracle_median,
                p.one_view_mean,
                p.one_view_median,
                p.one_view_log,
                p.dab_p95_ms,
                p.full_table_ms
            ));
        }
        out
    }

    /// Two markdown tables (by size, by K) for docs/BENCHMARKS.md.
    pub fn markdown(&self) -> String {
        let mut out = format!(
            "## Database size and K\n\n{} held-out materials (the quick set), one view (the paper's \
             configuration), HDR paint; mean and median relative RMSE. Machine: {}. Plot: \
             `bench_scaling.png`.\n\n",
            self.held_out, self.machine
        );
        out.push_str(&format!(
            "At K = {}:\n\n| database materials | basis | oracle mean | oracle median | one view \
             mean | one view median | one view log RMSE |\n|---|---|---|---|---|---|---|\n",
            self.default_components
        ));
        for p in self.by_size() {
            out.push_str(&format!(
                "| {} | {} in {:.1} s | {:.3} | {:.3} | {:.3} | {:.3} | {:.3} |\n",
                p.materials,
                p.basis,
                p.basis_seconds,
                p.oracle_mean,
                p.oracle_median,
                p.one_view_mean,
                p.one_view_median,
                p.one_view_log
            ));
        }
        out.push_str(&format!(
            "\nAt {} materials:\n\n| K | oracle mean | oracle median | one view mean | one view \
             median | one view log RMSE | 500-pixel dab p95 (ms) | full table (ms) |\n\
             |---|---|---|---|---|---|---|---|\n",
            self.default_size
        ));
        for p in self.by_components() {
            out.push_str(&format!(
                "| {} | {:.3} | {:.3} | {:.3} | {:.3} | {:.3} | {:.3} | {:.1} |\n",
                p.components,
                p.oracle_mean,
                p.oracle_median,
                p.one_view_mean,
                p.one_view_median,
                p.one_view_log,
                p.dab_p95_ms,
                p.full_table_ms
            ));
        }
        out
    }

    /// Writes `bench_scaling.csv`, `bench_scaling.png` and `SCALING.md` into `dir`.
    pub fn write_outputs(&self, dir: &Path) -> Result<()> {
        std::fs::create_dir_all(dir).map_err(|e| Error::io(dir, e))?;
        let csv = self.csv();
        write_atomically(&dir.join("bench_scaling.csv"), |w| {
            w.write_all(csv.as_bytes())
        })?;
        let png_path = dir.join("bench_scaling.png");
        let png = self
            .png()
            .map_err(|problem| Error::invalid(&png_path, problem))?;
        write_atomically(&png_path, |w| w.write_all(&png))?;
        let md = self.markdown();
        write_atomically(&dir.join("SCALING.md"), |w| w.write_all(md.as_bytes()))
    }

    /// Relative RMSE against database size (left) and K (right): oracle and one view, mean and
    /// median.
    pub fn png(&self) -> std::result::Result<Vec<u8>, String> {
        const WIDTH: u32 = 1400;
        const HEIGHT: u32 = 700;
        super::plot::register_font()?;
        let err = |e: &dyn std::fmt::Display| e.to_string();
        let mut buffer = vec![0u8; (WIDTH * HEIGHT * 3) as usize];
        {
            let root = BitMapBackend::with_buffer(&mut buffer, (WIDTH, HEIGHT)).into_drawing_area();
            root.fill(&WHITE).map_err(|e| err(&e))?;
            let (title, body) = root.split_vertically(70);
            title
                .draw(&Text::new(
                    format!(
                        "Burnish: error against database size and K ({} held-out materials)",
                        self.held_out
                    ),
                    (20, 10),
                    (super::plot::FONT, 28).into_font(),
                ))
                .map_err(|e| err(&e))?;
            title
                .draw(&Text::new(
                    self.machine.clone(),
                    (20, 45),
                    (super::plot::FONT, 16)
                        .into_font()
                        .color(&RGBColor(90, 90, 90)),
                ))
                .map_err(|e| err(&e))?;
            let (left, right) = body.split_horizontally(WIDTH / 2);
            let by_size: Vec<(f64, &ScalingPoint)> = self
                .by_size()
                .into_iter()
                .map(|p| (p.materials as f64, p))
                .collect();
            let by_k: Vec<(f64, &ScalingPoint)> = self
                .by_components()
                .into_iter()
                .map(|p| (p.components as f64, p))
                .collect();
            panel(
                &left,
                &by_size,
                &format!("database materials (K = {}, log)", self.default_components),
            )?;
            panel(
                &right,
                &by_k,
                &format!("K ({} materials, log)", self.default_size),
            )?;
            root.present().map_err(|e| err(&e))?;
        }
        super::plot::encode_png(&buffer, WIDTH, HEIGHT)
    }
}

/// A curve of a panel: its legend, its colour and the figure it plots.
type Curve = (&'static str, RGBColor, fn(&ScalingPoint) -> f64);

/// One panel: four curves over `points` (x, point).
fn panel(
    area: &DrawingArea<BitMapBackend, plotters::coord::Shift>,
    points: &[(f64, &ScalingPoint)],
    x_desc: &str,
) -> std::result::Result<(), String> {
    let err = |e: &dyn std::fmt::Display| e.to_string();
    let curves: [Curve; 4] = [
        ("one view, mean", RGBColor(31, 119, 180), |p| {
            p.one_view_mean
        }),
        ("one view, median", RGBColor(31, 119, 180), |p| {
            p.one_view_median
        }),
        ("oracle, mean", RGBColor(214, 39, 40), |p| p.oracle_mean),
        ("oracle, median", RGBColor(214, 39, 40), |p| p.oracle_median),
    ];
    let finite = |v: f64| v.is_finite() && v > 0.0;
    let xs: Vec<f64> = points
        .iter()
        .map(|(x, _)| *x)
        .filter(|x| *x > 0.0)
        .collect();
    let ys: Vec<f64> = points
        .iter()
        .flat_map(|(_, p)| curves.iter().map(|(_, _, f)| f(p)))
        .filter(|v| finite(*v))
        .collect();
    let (x0, x1) = xs
        .iter()
        .fold((f64::MAX, f64::MIN), |(a, b), &x| (a.min(x), b.max(x)));
    let (y0, y1) = ys
        .iter()
        .fold((f64::MAX, f64::MIN), |(a, b), &y| (a.min(y), b.max(y)));
    let (x0, x1) = if xs.is_empty() {
        (1.0, 10.0)
    } else {
        (x0 / 1.2, x1 * 1.2)
    };
    // Headroom above the curves for the legend.
    let (y0, y1) = if ys.is_empty() {
        (0.1, 1.0)
    } else {
        (y0 / 1.3, y1 * 2.2)
    };
    let font = super::plot::FONT;
    let mut chart = ChartBuilder::on(area)
        .margin(20)
        .x_label_area_size(55)
        .y_label_area_size(80)
        .build_cartesian_2d(
            // The measured sizes and K are the ticks.
            (x0..x1).log_scale().with_key_points(xs.clone()),
            (y0..y1)
                .log_scale()
                .with_key_points(super::plot::ticks(y0, y1)),
        )
        .map_err(|e| err(&e))?;
    chart
        .configure_mesh()
        .x_desc(x_desc)
        .y_desc("relative RMSE of ρ·cosθl·cosθv (log)")
        .label_style((font, 16))
        .axis_desc_style((font, 18))
        .x_label_formatter(&|x| super::plot::tick(*x))
        .y_label_formatter(&|y| super::plot::tick(*y))
        .draw()
        .map_err(|e| err(&e))?;
    for (i, (label, colour, value)) in curves.into_iter().enumerate() {
        let line: Vec<(f64, f64)> = points
            .iter()
            .map(|(x, p)| (*x, value(p)))
            .filter(|(_, y)| finite(*y))
            .collect();
        // Means: thick lines, filled markers; medians: thin lines, hollow markers.
        let style = ShapeStyle::from(&colour).stroke_width(if i % 2 == 0 { 3 } else { 1 });
        chart
            .draw_series(LineSeries::new(line.iter().copied(), style))
            .map_err(|e| err(&e))?
            .label(label)
            .legend(move |(x, y)| PathElement::new(vec![(x, y), (x + 20, y)], style));
        chart
            .draw_series(line.iter().map(|&(x, y)| {
                if i % 2 == 0 {
                    Circle::new((x, y), 6, colour.filled())
                } else {
                    Circle::new((x, y), 6, colour.stroke_width(2))
                }
            }))
            .map_err(|e| err(&e))?;
    }
    chart
        .configure_series_labels()
        .position(SeriesLabelPosition::UpperRight)
        .label_font((font, 16))
        .background_style(WHITE.mix(0.85))
        .border_style(BLACK)
        .draw()
        .map_err(|e| err(&e))?;
    Ok(())
}
