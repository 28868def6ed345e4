//! The benchmark's outputs: per-material CSV, aggregates, the JSON line and the Markdown page.

use super::live::LiveLoop;
pub use super::plot::Aggregate;
use super::{BenchOptions, Method, Row, policy_name, regularization_name};
use crate::error::{Error, Result};
use crate::fs_atomic::write_atomically;
use std::fmt::Write as _;
use std::io::Write as _;
use std::path::Path;

mod markdown;

/// The machine the figures were taken on.
#[derive(Clone, Debug, PartialEq)]
pub struct Machine {
    pub cpu: String,
    pub cores: usize,
    /// /proc/loadavg's 1, 5 and 15 minute loads when the run started.
    pub load_before: String,
    pub load_after: String,
    pub rustc: String,
    pub profile: &'static str,
}

impl Machine {
    pub fn probe() -> Self {
        let cpu = std::fs::read_to_string("/proc/cpuinfo")
            .ok()
            .and_then(|s| {
                s.lines()
                    .find(|l| l.starts_with("model name"))
                    .and_then(|l| l.split(':').nth(1))
                    .map(|m| m.trim().to_string())
            })
            .unwrap_or_else(|| std::env::consts::ARCH.to_string());
        let rustc = std::process::Command::new("rustc")
            .arg("--version")
            .output()
            .ok()
            .filter(|o| o.status.success())
            .map(|o| String::from_utf8_lossy(&o.stdout).trim().to_string())
            .unwrap_or_else(|| format!("rustc {} (MSRV)", env!("CARGO_PKG_RUST_VERSION")));
        Self {
            cpu,
            cores: std::thread::available_parallelism().map_or(1, |n| n.get()),
            load_before: load_average(),
            load_after: String::new(),
            rustc,
            profile: if cfg!(debug_assertions) {
                "debug"
            } else {
                "release"
            },
        }
    }

    /// One line: "AMD EPYC, 2 cores, rustc 1.95.0, release".
    pub fn describe(&self) -> String {
        format!(
            "{}, {} cores, {}, {} build",
            self.cpu, self.cores, self.rustc, self.profile
        )
    }
}

fn load_average() -> String {
    std::fs::read_to_string("/proc/loadavg")
        .map(|s| s.split_whitespace().take(3).collect::<Vec<_>>().join(" "))
        .unwrap_or_else(|_| "unknown".into())
}

fn mean(v: impl Iterator<Item = f64>) -> f64 {
    let (sum, n) = v.fold((0.0, 0usize), |(s, n), x| (s + x, n + 1));
    if n == 0 { f64::NAN } else { sum / n as f64 }
}

/// The median; the mean of the two middle values for an even count.
fn median(v: &mut [f64]) -> f64 {
    let n = v.len();
    if n == 0 {
        return f64::NAN;
    }
    v.sort_by(f64::total_cmp);
    if n % 2 == 1 {
        v[n / 2]
    } else {
        0.5 * (v[n / 2 - 1] + v[n / 2])
    }
}

/// Aggregates rows by method, in first-seen order.
pub fn aggregate(rows: &[Row]) -> Vec<Aggregate> {
    let mut labels: Vec<String> = Vec::new();
    for r in rows {
        let l = r.method.label();
        if !labels.contains(&l) {
            labels.push(l);
        }
    }
    labels
        .iter()
        .map(|label| {
            let of: Vec<&Row> = rows.iter().filter(|r| &r.method.label() == label).collect();
            let mut rel: Vec<f64> = of.iter().map(|r| r.relative_rmse).collect();
            Aggregate {
                method: of[0].method,
                axis: of[0].axis,
                materials: of.len(),
                mean_relative_rmse: mean(rel.iter().copied()),
                median_relative_rmse: median(&mut rel),
                mean_log_rmse: mean(of.iter().map(|r| r.log_rmse)),
                mean_median_psnr_db: mean(of.iter().map(|r| r.median_psnr_db)),
                mean_time_ms: mean(of.iter().map(|r| r.time_ms)),
                mean_relative_rmse_not_lambert_ggx: mean(
                    of.iter()
                        .filter(|r| !r.lambert_ggx)
                        .map(|r| r.relative_rmse),
                ),
                mean_relative_rmse_lambert_ggx: mean(
                    of.iter().filter(|r| r.lambert_ggx).map(|r| r.relative_rmse),
                ),
            }
        })
        .collect()
}

/// Everything one run measured.
#[derive(Clone, Debug)]
pub struct BenchReport {
    pub mode: &'static str,
    pub machine: Machine,
    pub rows: Vec<Row>,
    pub aggregates: Vec<Aggregate>,
    pub live: LiveLoop,
    pub stability: Vec<super::stability::StabilityCase>,
    /// The suggested-against-random next view trial, one entry per material.
    pub next_view: Vec<super::next_view_trial::NextViewTrial>,
    /// (K, how it came, seconds) for every basis the run used.
    pub bases: Vec<(usize, String, f64)>,
    pub basis_materials: usize,
    pub paper: super::Config,
    pub seconds: f64,
}

/// What a run measured besides the per-material rows.
pub(crate) struct Measured {
    pub live: LiveLoop,
    pub stability: Vec<super::stability::StabilityCase>,
    pub next_view: Vec<super::next_view_trial::NextViewTrial>,
}

impl BenchReport {
    pub(crate) fn new(
        options: &BenchOptions,
        mut machine: Machine,
        rows: Vec<Row>,
        measured: Measured,
        bases: Vec<(usize, String, f64)>,
        seconds: f64,
    ) -> Self {
        let Measured {
            live,
            stability,
            next_view,
        } = measured;
        machine.load_after = load_average();
        let aggregates = aggregate(&rows);
        Self {
            mode: options.mode,
            machine,
            rows,
            aggregates,
            live,
            stability,
            next_view,
            bases,
            basis_materials: options.basis_materials,
            paper: options.paper,
            seconds,
        }
    }

    fn find(&self, method: &Method) -> Option<&Aggregate> {
        let label = method.label();
        self.aggregates.iter().find(|a| a.method.label() == label)
    }

    /// The paper's configuration.
    pub fn paper(&self) -> Option<&Aggregate> {
        self.find(&Method::Sparse(self.paper))
    }

    /// The paper's configuration with `views` views.
    pub fn paper_views(&self, views: usize) -> Option<&Aggregate> {
        self.find(&Method::Sparse(super::Config {
            views,
            ..self.paper
        }))
    }

    /// The paper's configuration with LDR (8-bit, clipped) paint.
    pub fn paper_ldr(&self) -> Option<&Aggregate> {
        self.find(&Method::Sparse(super::Config {
            paint: super::Paint::Ldr,
            ..self.paper
        }))
    }

    /// The oracle at the paper's K.
    pub fn oracle(&self) -> Option<&Aggregate> {
        self.find(&Method::Oracle {
            components: self.paper.components,
        })
    }

    /// The analytic fit of the paper's (one-view) samples.
    pub fn analytic(&self) -> Option<&Aggregate> {
        self.find(&Method::Analytic {
            views: self.paper.views,
            resolution: self.paper.resolution,
            paint: self.paper.paint,
        })
    }

    /// The 500-pixel dab at the paper's K (or the nearest size timed).
    pub fn dab(&self) -> Option<&super::live::DabTiming> {
        self.live
            .dabs
            .iter()
            .filter(|d| d.components == self.paper.components)
            .min_by_key(|d| d.changed_pixels.abs_diff(500))
    }

    fn paper_k(&self) -> Option<&super::live::PerComponents> {
        self.live
            .per_components
            .iter()
            .find(|p| p.components == self.paper.components)
    }

    /// The figures (and a few more) as (key, value) pairs, in output order.
    pub fn key_figures(&self) -> Vec<(&'static str, f64)> {
        let nan = f64::NAN;
        let pick = |a: Option<&Aggregate>, f: fn(&Aggregate) -> f64| a.map_or(nan, f);
        vec![
            ("dab_solve_ms_p50", self.dab().map_or(nan, |d| d.p50_ms)),
            ("dab_solve_ms_p95", self.dab().map_or(nan, |d| d.p95_ms)),
            (
                "full_table_ms",
                self.paper_k().map_or(nan, |p| p.full_table_ms),
            ),
            ("basis_load_ms", self.live.basis_load_ms),
            (
                "rel_rmse_1view_k20",
                pick(self.paper(), |a| a.mean_relative_rmse),
            ),
            (
                "rel_rmse_oracle_k20",
                pick(self.oracle(), |a| a.mean_relative_rmse),
            ),
            (
                "rel_rmse_analytic_fit",
                pick(self.analytic(), |a| a.mean_relative_rmse),
            ),
            (
                "median_rel_rmse_1view_k20",
                pick(self.paper(), |a| a.median_relative_rmse),
            ),
            (
                "median_rel_rmse_oracle_k20",
                pick(self.oracle(), |a| a.median_relative_rmse),
            ),
            (
                "median_rel_rmse_analytic_fit",
                pick(self.analytic(), |a| a.median_relative_rmse),
            ),
            (
                "rel_rmse_1view_k20_not_lambert_ggx",
                pick(self.paper(), |a| a.mean_relative_rmse_not_lambert_ggx),
            ),
            (
                "rel_rmse_analytic_fit_not_lambert_ggx",
                pick(self.analytic(), |a| a.mean_relative_rmse_not_lambert_ggx),
            ),
            (
                "worst_condition_number",
                self.worst_condition().map_or(nan, |c| c.condition_number),
            ),
            (
                "log_rmse_1view_k20",
                pick(self.paper(), |a| a.mean_log_rmse),
            ),
            (
                "log_rmse_oracle_k20",
                pick(self.oracle(), |a| a.mean_log_rmse),
            ),
            (
                "log_rmse_analytic_fit",
                pick(self.analytic(), |a| a.mean_log_rmse),
            ),
            (
                "psnr_db_1view_k20",
                pick(self.paper(), |a| a.mean_median_psnr_db),
            ),
            (
                "reconstruct_ms_1view_k20",
                pick(self.paper(), |a| a.mean_time_ms),
            ),
            (
                "rebuild_normal_equations_ms",
                self.paper_k().map_or(nan, |p| p.rebuild_ms),
            ),
            (
                "rel_rmse_3view",
                pick(self.paper_views(3), |a| a.mean_relative_rmse),
            ),
            (
                "median_rel_rmse_3view",
                pick(self.paper_views(3), |a| a.median_relative_rmse),
            ),
            (
                "log_rmse_3view",
                pick(self.paper_views(3), |a| a.mean_log_rmse),
            ),
            (
                "rel_rmse_1view_ldr",
                pick(self.paper_ldr(), |a| a.mean_relative_rmse),
            ),
            (
                "median_rel_rmse_1view_ldr",
                pick(self.paper_ldr(), |a| a.median_relative_rmse),
            ),
            (
                "rel_rmse_2view_suggested",
                self.next_view_mean(|t| t.suggested),
            ),
            (
                "rel_rmse_2view_random",
                self.next_view_mean(|t| t.random_mean()),
            ),
            ("next_view_suggestion_wins", self.next_view_wins()),
            ("lazy_preview_ms", self.live.lazy_ms),
            ("lazy_preview_entries", self.live.lazy_entries as f64),
            ("seconds", self.seconds),
        ]
    }

    /// Mean of `figure` over the next-view trial's materials (NaN without the trial).
    fn next_view_mean(
        &self,
        figure: impl Fn(&super::next_view_trial::NextViewTrial) -> f64,
    ) -> f64 {
        if self.next_view.is_empty() {
            return f64::NAN;
        }
        self.next_view.iter().map(figure).sum::<f64>() / self.next_view.len() as f64
    }

    /// Fraction of the trial's materials where the suggested view beats the random ones' mean.
    fn next_view_wins(&self) -> f64 {
        self.next_view_mean(|t| f64::from(u8::from(t.suggested < t.random_mean())))
    }

    /// One line of JSON with the key figures, the mode and the machine (a figure that is not
    /// finite is null).
    pub fn json(&self) -> String {
        let mut object = serde_json::Map::new();
        object.insert("mode".into(), self.mode.into());
        object.insert(
            "materials".into(),
            self.paper().map_or(0, |a| a.materials).into(),
        );
        for (key, value) in self.key_figures() {
            object.insert(key.into(), value.into());
        }
        object.insert("machine".into(), self.machine.describe().into());
        object.insert(
            "load_before".into(),
            self.machine.load_before.clone().into(),
        );
        object.insert("load_after".into(), self.machine.load_after.clone().into());
        serde_json::Value::Object(object).to_string()
    }

    /// One row per method and material.
    pub fn csv(&self) -> String {
        let mut out = String::from(
            "method,kind,axis,components,regularization,views,resolution,paint,policy,material,family,lambert_ggx,relative_rmse,log_rmse,median_psnr_db,time_ms,samples_used,observed_bins,pixels_background,pixels_shadow,pixels_grazing,grazing_mirror_share\n",
        );
        for r in &self.rows {
            let (k, reg, views, res, paint, policy) = match r.method {
                Method::Sparse(c) => (
                    c.components.to_string(),
                    regularization_name(c.regularization),
                    c.views.to_string(),
                    c.resolution.to_string(),
                    c.paint.name(),
                    policy_name(c.policy),
                ),
                Method::Oracle { components } => (
                    components.to_string(),
                    String::new(),
                    String::new(),
                    String::new(),
                    "",
                    "",
                ),
                Method::Analytic {
                    views,
                    resolution,
                    paint,
                } => (
                    String::new(),
                    String::new(),
                    views.to_string(),
                    resolution.to_string(),
                    paint.name(),
                    "mean",
                ),
            };
            let _ = writeln!(
                out,
                "{},{},{},{k},{reg},{views},{res},{paint},{policy},{},{},{},{:.6},{:.6},{:.3},{:.3},{},{},{},{},{},{:.4}",
                r.method.label(),
                r.method.kind(),
                r.axis,
                r.material,
                r.family,
                r.lambert_ggx,
                r.relative_rmse,
                r.log_rmse,
                r.median_psnr_db,
                r.time_ms,
                r.samples_used,
                r.observed_bins,
                r.counts.background,
                r.counts.shadow,
                r.counts.grazing,
                r.grazing_mirror_share,
            );
        }
        out
    }

    /// The worst-conditioned case of the probe.
    pub fn worst_condition(&self) -> Option<&super::stability::StabilityCase> {
        self.stability
            .iter()
            .max_by(|a, b| a.condition_number.total_cmp(&b.condition_number))
    }

    /// Writes `bench.csv`, `bench_pareto.png` and `BENCHMARKS.md` into `dir`, atomically.
    pub fn write_outputs(&self, dir: &Path, command: &str) -> Result<()> {
        std::fs::create_dir_all(dir).map_err(|e| Error::io(dir, e))?;
        let csv = self.csv();
        write_atomically(&dir.join("bench.csv"), |w| w.write_all(csv.as_bytes()))?;
        let png_path = dir.join("bench_pareto.png");
        let png = super::plot::pareto_png(&self.aggregates, &self.machine.describe())
            .map_err(|problem| Error::invalid(&png_path, problem))?;
        write_atomically(&png_path, |w| w.write_all(&png))?;
        let md = self.markdown(command);
        write_atomically(&dir.join("BENCHMARKS.md"), |w| w.write_all(md.as_bytes()))
    }
}
