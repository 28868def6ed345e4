//! The benchmark's outputs: per-material CSV, aggregates, the JSON line and the Markdown page.

use super::live::LiveLoop;
use super::{BenchOptions, Method, Row, policy_name, regularization_name};
use crate::error::{Error, Result};
use crate::fs_atomic::write_atomically;
use std::fmt::Write as _;
use std::io::Write as _;
use std::path::Path;

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

/// One method over every material.
#[derive(Clone, Debug, PartialEq)]
pub struct Aggregate {
    pub method: Method,
    pub axis: &'static str,
    pub materials: usize,
    pub mean_relative_rmse: f64,
    pub median_relative_rmse: f64,
    pub mean_log_rmse: f64,
    pub mean_median_psnr_db: f64,
    pub mean_time_ms: f64,
    /// Mean relative RMSE over the materials Lambert + GGX does not describe.
    pub mean_relative_rmse_not_lambert_ggx: f64,
    /// Mean relative RMSE over the materials Lambert + GGX describes.
    pub mean_relative_rmse_lambert_ggx: f64,
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

    /// The issue's figures (and a few more) as (key, value) pairs, in output order.
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

    fn next_view_section(&self, md: &mut String) {
        let Some(first) = self.next_view.first() else {
            return;
        };
        let _ = writeln!(md, "## Next view: suggested against random\n");
        let _ = writeln!(
            md,
            "Each held-out material is painted under view 0 (light {}°, {}°), the candidates of \
             `burnish suggest` are ranked for that painting, and a second view is painted at the \
             suggestion or at {} candidates drawn at random from the same list. Relative RMSE of \
             the two-view reconstruction (default prior, HDR paint):\n",
            super::VIEWS[0].light_elevation_deg,
            super::VIEWS[0].light_azimuth_deg,
            first.random.len()
        );
        let _ = writeln!(
            md,
            "| material | one view | suggested second view | light (el, az), camera (yaw, pitch) | random second view (mean) | random (each) |\n|---|---|---|---|---|---|"
        );
        for t in &self.next_view {
            let each: Vec<String> = t.random.iter().map(|r| format!("{r:.3}")).collect();
            let v = t.suggested_view;
            let _ = writeln!(
                md,
                "| {} | {:.3} | {:.3} | ({:.0}°, {:.0}°), ({:.0}°, {:.0}°) | {:.3} | {} |",
                t.material,
                t.one_view,
                t.suggested,
                v[0],
                v[1],
                v[2],
                v[3],
                t.random_mean(),
                each.join(", ")
            );
        }
        let _ = writeln!(
            md,
            "| **mean** | {:.3} | **{:.3}** | | **{:.3}** | |\n\nThe suggestion beats the random views' mean on {:.0}% of the materials.\n",
            self.next_view_mean(|t| t.one_view),
            self.next_view_mean(|t| t.suggested),
            self.next_view_mean(|t| t.random_mean()),
            100.0 * self.next_view_wins()
        );
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
            "method,kind,axis,components,regularization,views,resolution,paint,policy,material,family,lambert_ggx,relative_rmse,log_rmse,median_psnr_db,time_ms,samples_used,observed_bins,pixels_background,pixels_shadow,pixels_grazing\n",
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
                "{},{},{},{k},{reg},{views},{res},{paint},{policy},{},{},{},{:.6},{:.6},{:.3},{:.3},{},{},{},{},{}",
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
            );
        }
        out
    }

    /// The Markdown page; `command` is the line that reproduces it.
    pub fn markdown(&self, command: &str) -> String {
        let mut md = String::new();
        let m = &self.machine;
        let _ = writeln!(md, "# Benchmarks\n");
        let _ = writeln!(
            md,
            "Generated by `burnish bench` ({} mode) in {:.0} s on {}. Load average (1, 5, 15 min) {} at the start, {} at the end.\n",
            self.mode,
            self.seconds,
            m.describe(),
            m.load_before,
            m.load_after
        );
        let _ = writeln!(md, "Reproduce with:\n\n```sh\n{command}\n```\n");
        let _ = writeln!(
            md,
            "`burnish bench --quick --json` is the short run (one basis, K = {}, eight materials, \
             the paper's configuration, two views and LDR paint; under five minutes on two cores \
             including a cold basis build) whose last line is one JSON object with the figures \
             below. The full run sweeps every axis; it builds the bases it lacks (K = 5 to 80).\n",
            self.paper.components
        );
        self.goals_section(&mut md);
        self.error_section(&mut md);
        self.next_view_section(&mut md);
        self.live_section(&mut md);
        self.stability_section(&mut md);
        let _ = writeln!(
            md,
            "## Files\n\n- `bench.csv`: one row per method and material (every figure above comes from it).\n\
             - `bench_pareto.png`: mean relative RMSE against time per reconstruction, one point per configuration."
        );
        md
    }

    /// The worst-conditioned case of the probe.
    pub fn worst_condition(&self) -> Option<&super::stability::StabilityCase> {
        self.stability
            .iter()
            .max_by(|a, b| a.condition_number.total_cmp(&b.condition_number))
    }

    fn stability_section(&self, md: &mut String) {
        let _ = writeln!(md, "## Numerical stability\n");
        let _ = writeln!(
            md,
            "The property tests (`tests/stress.rs`, proptest) and the fuzz target \
             (`fuzz/fuzz_targets/solver_ops.rs`, cargo-fuzz) drive the sparse table and the solver \
             with random add/replace/remove sequences, duplicates, NaN/Inf/negative input (refused), \
             values from 1e-6 to 1e6, nearly collinear rows, K above the observed bin count and λ \
             from 0 to 1e300. They check finite output, ρ ≥ 0, reciprocity, bit-identical results \
             across runs and thread counts, and incremental = batch. The probe below solves the \
             hardest of those systems with this run's basis (K = {}) and materialises each table.\n",
            self.paper.components
        );
        let _ = writeln!(
            md,
            "| system | regularisation | bins | condition number | α or λ used | max \\|x\\| | ρ min | ρ max | finite, ≥ 0 | log distance from mean material |\n\
             |---|---|---|---|---|---|---|---|---|---|"
        );
        for c in &self.stability {
            let _ = writeln!(
                md,
                "| {} | {} | {} | {:.3e} | {:.3e} | {:.3e} | {:.3e} | {:.3e} | {} | {:.3} |",
                c.name,
                super::regularization_name(c.regularization),
                c.observed_bins,
                c.condition_number,
                c.alpha,
                c.max_coefficient,
                c.min_rho,
                c.max_rho,
                if c.physical { "yes" } else { "**no**" },
                c.log_distance_from_mean
            );
        }
        if let Some(worst) = self.worst_condition() {
            let _ = writeln!(
                md,
                "\nWorst condition number: **{:.3e}** ({}, {}). The solver factors the \
                 regularised normal matrix N + Λ by Cholesky (`llt`); Λ > 0 keeps it positive \
                 definite, and where rounding still defeats the factorisation it adds a jitter of \
                 1e-12 ‖N‖ and retries, then falls back to the mean material. Any non-finite \
                 coefficient is zeroed, the condition number is capped at 1/ε, and ρ is clamped \
                 to the basis's per-pair range in the log domain before it is mapped back, so even \
                 this system gives a finite, non-negative, reciprocal table (above). With \
                 λ or α near zero the few observed bins are fitted exactly and the rest follow \
                 the basis's clamp; with huge α the answer is the mean material.\n",
                worst.condition_number,
                worst.name,
                super::regularization_name(worst.regularization)
            );
        }
    }

    fn goals_section(&self, md: &mut String) {
        let _ = writeln!(md, "## Goals\n");
        let _ = writeln!(md, "| goal | target | measured | met |\n|---|---|---|---|");
        let yes = |b: bool| if b { "yes" } else { "no" };
        if let (Some(p), Some(o)) = (self.paper(), self.oracle()) {
            let ratio = p.mean_relative_rmse / o.mean_relative_rmse;
            let _ = writeln!(
                md,
                "| one view within 2× the oracle at K = {} (mean relative RMSE) | ≤ 2× | {:.3} vs {:.3} ({ratio:.2}×) | {} |",
                self.paper.components,
                p.mean_relative_rmse,
                o.mean_relative_rmse,
                yes(ratio <= 2.0)
            );
            let log_ratio = p.mean_log_rmse / o.mean_log_rmse;
            let _ = writeln!(
                md,
                "| (the same in the oracle's own criterion, mean log-mapped RMSE) | ≤ 2× | {:.3} vs {:.3} ({log_ratio:.2}×) | {} |",
                p.mean_log_rmse,
                o.mean_log_rmse,
                yes(log_ratio <= 2.0)
            );
        }
        if let (Some(p), Some(a)) = (self.paper(), self.analytic()) {
            let (s, f) = (
                p.mean_relative_rmse_not_lambert_ggx,
                a.mean_relative_rmse_not_lambert_ggx,
            );
            let _ = writeln!(
                md,
                "| better than the analytic fit on materials that are not Lambert + GGX | lower | {s:.3} vs {f:.3} | {} |",
                yes(s < f)
            );
            let _ = writeln!(
                md,
                "| (for reference) on the Lambert + GGX materials | — | {:.3} vs {:.3} | — |",
                p.mean_relative_rmse_lambert_ggx, a.mean_relative_rmse_lambert_ggx
            );
        }
        if let Some(d) = self.dab() {
            let _ = writeln!(
                md,
                "| {}-pixel dab re-solved, K = {} (p50 / p95) | ≤ 1 ms | {:.3} / {:.3} ms | {} |",
                d.changed_pixels,
                d.components,
                d.p50_ms,
                d.p95_ms,
                yes(d.p50_ms <= 1.0)
            );
        }
        if let Some(p) = self.paper_k() {
            let _ = writeln!(
                md,
                "| full table, K = {} (median) | ≤ 50 ms | {:.1} ms | {} |",
                p.components,
                p.full_table_ms,
                yes(p.full_table_ms <= 50.0)
            );
        }
        let _ = writeln!(md);
        let _ = writeln!(
            md,
            "Key figures (the JSON line):\n\n```json\n{}\n```\n",
            self.json()
        );
    }

    fn error_section(&self, md: &mut String) {
        let _ = writeln!(md, "## Run time against error\n");
        let materials: Vec<(&str, &str, bool)> = {
            let mut seen: Vec<(&str, &str, bool)> = Vec::new();
            for r in &self.rows {
                if !seen.iter().any(|s| s.0 == r.material) {
                    seen.push((&r.material, r.family, r.lambert_ggx));
                }
            }
            seen
        };
        let lggx = materials.iter().filter(|m| m.2).count();
        let _ = writeln!(
            md,
            "{} held-out materials: database materials from seed {:#x} (the basis database uses {:#x}, {} materials) and hand-built ones \
             the generator never makes; {} of them are Lambert + GGX, the analytic model's own family. Each is rendered \
             at each pixel's exact directions as a perfect painter would paint it, on the default sphere scene \
             (views: {}), turned into samples like a painting, reconstructed and scored with `burnish eval`'s metrics \
             against its tabulated truth: relative RMSE of ρ·cos θ_l·cos θ_v over the full table, RMSE in the \
             log-mapped domain, median PSNR of eight sphere renders. Time is samples → full table (sample \
             extraction, binning, normal equations, solve or fit, materialisation); the oracle's is its projection. \
             The paper's configuration is `{}` (K, regularisation, views, guide resolution, paint, sample policy); \
             every other row changes one axis.\n",
            materials.len(),
            super::held_out::HELD_OUT_SEED,
            crate::materials::database::DatabaseSpec::default().seed,
            self.basis_materials,
            lggx,
            super::VIEWS
                .iter()
                .map(|v| format!(
                    "light ({}°, {}°), camera yaw {}° pitch {}°",
                    v.light_elevation_deg,
                    v.light_azimuth_deg,
                    v.camera_yaw_deg,
                    v.camera_pitch_deg
                ))
                .collect::<Vec<_>>()
                .join("; "),
            self.paper.label()
        );
        let _ = writeln!(
            md,
            "| method | axis | materials | mean rel. RMSE | median rel. RMSE | mean log RMSE | mean PSNR (dB) | mean time (ms) |\n|---|---|---|---|---|---|---|---|"
        );
        for a in &self.aggregates {
            let _ = writeln!(
                md,
                "| `{}` | {} | {} | {:.3} | {:.3} | {:.3} | {:.1} | {:.1} |",
                a.method.label(),
                a.axis,
                a.materials,
                a.mean_relative_rmse,
                a.median_relative_rmse,
                a.mean_log_rmse,
                a.mean_median_psnr_db,
                a.mean_time_ms
            );
        }
        let _ = writeln!(md, "\n![Pareto plot](bench_pareto.png)\n");
        let _ = writeln!(
            md,
            "Per material (relative RMSE): the paper's configuration, the oracle and the analytic fit.\n"
        );
        let paper = super::Method::Sparse(self.paper).label();
        let oracle = super::Method::Oracle {
            components: self.paper.components,
        }
        .label();
        let analytic = super::Method::Analytic {
            views: self.paper.views,
            resolution: self.paper.resolution,
            paint: self.paper.paint,
        }
        .label();
        let _ = writeln!(
            md,
            "| material | family | Lambert + GGX | `{paper}` | `{oracle}` | `{analytic}` |\n|---|---|---|---|---|---|"
        );
        for (name, family, lg) in &materials {
            let value = |label: &str| {
                self.rows
                    .iter()
                    .find(|r| r.material == *name && r.method.label() == label)
                    .map_or("—".to_string(), |r| format!("{:.3}", r.relative_rmse))
            };
            let _ = writeln!(
                md,
                "| {name} | {family} | {} | {} | {} | {} |",
                if *lg { "yes" } else { "no" },
                value(&paper),
                value(&oracle),
                value(&analytic)
            );
        }
        let _ = writeln!(md);
    }

    fn live_section(&self, md: &mut String) {
        let l = &self.live;
        let _ = writeln!(md, "## Live loop\n");
        let _ = writeln!(
            md,
            "On view 0 at {}², fully painted with `{}` (HDR), K as listed, default prior. A dab sets the \
             samples of its changed pixels (the N painted pixels nearest a random centre, scaled by a random \
             factor), updates the normal equations and solves (with the condition number); timed over {} dabs.\n",
            l.resolution,
            l.material,
            l.dabs.first().map_or(0, |d| d.repeats)
        );
        let _ = writeln!(
            md,
            "| K | changed pixels | bin updates (mean) | distinct bins (mean) | p50 (ms) | p95 (ms) |\n|---|---|---|---|---|---|"
        );
        for d in &l.dabs {
            let _ = writeln!(
                md,
                "| {} | {} | {:.0} | {:.0} | {:.3} | {:.3} |",
                d.components, d.changed_pixels, d.bin_updates, d.distinct_bins, d.p50_ms, d.p95_ms
            );
        }
        let _ = writeln!(
            md,
            "\n| K | observed bins | full table (ms) | normal equations rebuilt from scratch (ms) |\n|---|---|---|---|"
        );
        for p in &l.per_components {
            let _ = writeln!(
                md,
                "| {} | {} | {:.1} | {:.2} |",
                p.components, p.observed_bins, p.full_table_ms, p.rebuild_ms
            );
        }
        let _ = writeln!(
            md,
            "\nLazy evaluation for a preview of this view: {} entries in {:.2} ms, against the full table's \
             {} entries in {:.1} ms (K = {}, medians).\n",
            l.lazy_entries, l.lazy_ms, l.full_entries, l.full_ms, self.paper.components
        );
        let _ = writeln!(
            md,
            "Basis: loading the K = {} cache file (map, checksum, checks) takes {:.1} ms (median). This run:",
            self.paper.components, l.basis_load_ms
        );
        for (k, how, s) in &self.bases {
            let _ = writeln!(
                md,
                "- K = {k} ({} materials): {how} in {s:.1} s",
                self.basis_materials
            );
        }
        let _ = writeln!(md, "\n### What the scene lets the loop skip\n");
        let _ = writeln!(
            md,
            "Pixels of each built-in object's default guide ({}², light (45°, 30°)):\n",
            l.resolution
        );
        let _ = writeln!(
            md,
            "| object | pixels | samples | background | shadow | grazing / below horizon |\n|---|---|---|---|---|---|"
        );
        for (name, c) in &l.scene_skips {
            let _ = writeln!(
                md,
                "| {name} | {} | {} | {} | {} | {} |",
                c.total(),
                c.used,
                c.background,
                c.shadow,
                c.grazing
            );
        }
        let s = &l.stroke;
        let _ = writeln!(
            md,
            "\nA stroke of {} round dabs (radius {:.1} px, spaced half a radius) from corner to corner of view 0 \
             in one colour covered {} pixels: {} background, {} shadow, {} grazing or below the horizon, {} \
             unchanged (already that colour: the overlap with the previous dab) and {} changed, which made \
             {} bin updates in {} distinct bins. Median time per dab (samples, normal equations, solve): {:.3} ms.\n",
            s.dabs,
            s.brush_radius_px,
            s.pixels,
            s.background,
            s.shadow,
            s.grazing,
            s.unchanged,
            s.changed,
            s.bin_updates,
            s.distinct_bins,
            s.p50_ms_per_dab
        );
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
