//! Leave-families-out cross-validation of the prior's constants on the database itself.
//!
//! The prior's strength α, its band correlation ρ and the brightness weights (β, κ) must be
//! chosen on data the engine owns, never on the bench's held-out materials. The database's
//! families are split into folds; for each fold a basis is built from the other families only,
//! and materials of the left-out families, drawn from [`CALIBRATION_SEED`] (a seed neither the
//! default basis nor the bench uses), are painted by a perfect painter under several view sets
//! and rebuilt under every candidate prior. A left-out family is unlike everything the fold's
//! basis saw, which is what a material an artist paints is to the real basis.
//!
//! Candidates are ranked by the geometric mean of the relative RMSE over every (material,
//! view set, paint) case: scale-free, so a few sharp materials with large errors do not decide
//! alone. Paint is HDR and 8-bit LDR (clipped highlights, whose bins are bounds), so the
//! constants of the censored solve ([`Censoring`]) are chosen here too.

use super::VIEWS;
use crate::basis::{Basis, BasisCache, BasisSpec, build::build_basis_from};
use crate::error::Result;
use crate::materials::database::{DatabaseSpec, Family, family_of, material};
use crate::materials::tabulate;
use crate::metrics::table_errors;
use crate::scene::{
    CameraSettings, GBuffer, LightSettings, Object, PaintRange, Scene, render_table,
    samples_from_image_in,
};
use crate::solver::{
    BinChange, Censoring, KnotSpacing, Policy, PriorMean, PriorModel, Reconstruction,
    Regularization, Solver, SparseTable,
};
use rayon::prelude::*;
use std::sync::Arc;
use std::time::Instant;

/// The seed of the calibration's test materials: differs from the default database's and
/// from the bench's held-out seed.
pub const CALIBRATION_SEED: u64 = 0xca11_b8a7;

/// One prior to score.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Candidate {
    /// The prior's strength (see [`Regularization::Prior`]).
    pub alpha: f64,
    pub model: PriorModel,
}

impl Candidate {
    pub fn label(&self) -> String {
        let m = self.model;
        if m == PriorModel::GLOBAL {
            format!("global α={}", self.alpha)
        } else {
            format!(
                "bands={} {} ℓ={} α={} ρ={}{} β={} κ={} {} mean={}",
                m.bands,
                m.knots.name(),
                m.band_length,
                self.alpha,
                m.band_correlation,
                if m.correlation_by_evidence { "+ev" } else { "" },
                m.brightness_exponent,
                m.brightness_floor,
                m.censoring.name(),
                m.mean.name()
            )
        }
    }
}

/// One light and camera (degrees, SCENE.md conventions).
type ViewAngles = (f64, f64, f64, f64);

/// The view sets every test material is painted under: the bench's one and three lights, and
/// a second family of one and three views that also turn the camera, so the constants are not
/// fitted to one arrangement of lights.
pub fn view_sets() -> Vec<Vec<ViewAngles>> {
    let bench = |v: &super::ViewSetup| {
        (
            v.light_elevation_deg,
            v.light_azimuth_deg,
            v.camera_yaw_deg,
            v.camera_pitch_deg,
        )
    };
    let turned = vec![
        (70.0, -40.0, 0.0, 0.0),
        (30.0, 80.0, 25.0, 10.0),
        (15.0, 170.0, -20.0, 0.0),
    ];
    vec![
        vec![bench(&VIEWS[0])],
        VIEWS[..3].iter().map(bench).collect(),
        turned[..1].to_vec(),
        turned,
    ]
}

/// What a calibration run does.
#[derive(Clone, Debug)]
pub struct CalibrateOptions {
    /// Where the folds' bases are cached (one folder per fold under it).
    pub cache: BasisCache,
    /// Groups the families are split into; each is left out once.
    pub folds: usize,
    /// Materials in each fold's database.
    pub basis_materials: usize,
    pub components: usize,
    /// Test materials per fold, from the left-out families.
    pub tests_per_fold: usize,
    /// Guide resolution of the paintings.
    pub resolution: u32,
    /// How the test materials are painted: HDR (exact values) and 8-bit LDR (clipped at 1,
    /// quantised, its clipped bins bounds), each under every view set.
    pub paints: Vec<PaintRange>,
    pub candidates: Vec<Candidate>,
}

impl CalibrateOptions {
    /// The run whose result the default constants come from: 4 folds of the default database
    /// size, 6 test materials each, a grid around the localised prior and the global prior.
    pub fn standard(cache: BasisCache) -> Self {
        Self {
            cache,
            folds: 4,
            basis_materials: DatabaseSpec::default().size,
            components: BasisSpec::DEFAULT_COMPONENTS,
            tests_per_fold: 6,
            resolution: 256,
            paints: vec![PaintRange::Hdr, PaintRange::Ldr],
            candidates: Grid::standard().candidates(),
        }
    }
}

/// The candidates of a run as a grid: the global prior at each α, and the localised prior at
/// every combination of α, ρ and (β, κ).
#[derive(Clone, Debug, PartialEq)]
pub struct Grid {
    pub alphas: Vec<f64>,
    /// α values of the global prior (none: the global prior is not scored).
    pub global_alphas: Vec<f64>,
    pub band_correlations: Vec<f64>,
    /// (β, κ) pairs.
    pub brightness: Vec<(f64, f64)>,
    pub knots: Vec<KnotSpacing>,
    /// ℓ values ([`PriorModel::band_length`]).
    pub band_lengths: Vec<f64>,
    /// [`PriorModel::correlation_by_evidence`] settings.
    pub correlation_by_evidence: Vec<bool>,
    /// [`PriorModel::censoring`] settings (they change LDR cases only).
    pub censoring: Vec<Censoring>,
    /// [`PriorModel::mean`] settings.
    pub means: Vec<PriorMean>,
}

impl Grid {
    /// The grid of the first calibration run.
    pub fn standard() -> Self {
        Self {
            alphas: vec![3.0, 10.0, 30.0],
            global_alphas: vec![1.0, 3.0, 10.0, 30.0],
            band_correlations: vec![0.8, 0.9, 0.97],
            brightness: vec![(0.0, 1.0), (0.5, 0.3), (1.0, 0.3)],
            knots: vec![KnotSpacing::Uniform],
            band_lengths: vec![0.0],
            correlation_by_evidence: vec![true],
            censoring: vec![Censoring::CALIBRATED],
            means: vec![PriorModel::CALIBRATED.mean],
        }
    }

    pub fn candidates(&self) -> Vec<Candidate> {
        let mut candidates: Vec<Candidate> = self
            .global_alphas
            .iter()
            .map(|&alpha| Candidate {
                alpha,
                model: PriorModel::GLOBAL,
            })
            .collect();
        for (&knots, &band_length) in self
            .knots
            .iter()
            .flat_map(|k| self.band_lengths.iter().map(move |l| (k, l)))
        {
            for &alpha in &self.alphas {
                for &band_correlation in &self.band_correlations {
                    for &(brightness_exponent, brightness_floor) in &self.brightness {
                        for &correlation_by_evidence in &self.correlation_by_evidence {
                            for (&censoring, &mean) in self
                                .censoring
                                .iter()
                                .flat_map(|c| self.means.iter().map(move |m| (c, m)))
                            {
                                candidates.push(Candidate {
                                    alpha,
                                    model: PriorModel {
                                        band_correlation,
                                        brightness_exponent,
                                        brightness_floor,
                                        knots,
                                        band_length,
                                        correlation_by_evidence,
                                        censoring,
                                        mean,
                                        ..PriorModel::CALIBRATED
                                    },
                                });
                            }
                        }
                    }
                }
            }
        }
        candidates
    }
}

/// One candidate's figures over every case.
#[derive(Clone, Debug)]
pub struct CandidateScore {
    pub candidate: Candidate,
    /// exp(mean ln relative RMSE) over every case: what ranks the candidates.
    pub geometric_mean_relative_rmse: f64,
    pub mean_relative_rmse_1view: f64,
    pub median_relative_rmse_1view: f64,
    pub mean_relative_rmse_3view: f64,
    pub median_relative_rmse_3view: f64,
    pub mean_log_rmse: f64,
    /// The same four figures for 8-bit LDR paint (NaN when the run paints no LDR).
    pub mean_relative_rmse_1view_ldr: f64,
    pub median_relative_rmse_1view_ldr: f64,
    pub mean_relative_rmse_3view_ldr: f64,
    pub median_relative_rmse_3view_ldr: f64,
    /// Cases where three views are more than 10% worse than the first of them alone.
    pub views_hurt: usize,
    /// (material, one-and-three-view arrangement) pairs.
    pub comparisons: usize,
}

/// A finished calibration: the candidates, best first.
#[derive(Clone, Debug)]
pub struct Calibration {
    pub scores: Vec<CandidateScore>,
    /// (fold, left-out families, test material labels).
    pub folds: Vec<(usize, Vec<&'static str>, Vec<String>)>,
    pub seconds: f64,
}

/// The families fold `fold` leaves out.
pub fn left_out_families(fold: usize, folds: usize) -> Vec<Family> {
    Family::ALL
        .iter()
        .enumerate()
        .filter(|(i, _)| i % folds == fold)
        .map(|(_, &f)| f)
        .collect()
}

/// Indices of `seed`'s materials, in order, whose family `keep` accepts.
fn indices_where(keep: impl Fn(Family) -> bool, count: usize) -> Vec<usize> {
    (0..).filter(|&i| keep(family_of(i))).take(count).collect()
}

fn fold_basis(
    options: &CalibrateOptions,
    fold: usize,
    out: &[Family],
    log: &dyn Fn(&str),
) -> Result<Arc<Basis>> {
    let mut spec = BasisSpec::default_for(options.components);
    spec.database.size = options.basis_materials;
    let cache = BasisCache::at(
        options
            .cache
            .dir()
            .join(format!("calibration-{}folds-{fold}", options.folds)),
    );
    if let Ok(Some(basis)) = cache.load(&spec) {
        log(&format!("fold {fold}: basis loaded from the cache"));
        return Ok(Arc::new(basis));
    }
    let seed = spec.database.seed;
    let kept = indices_where(|f| !out.contains(&f), options.basis_materials);
    let source = move |i: usize| material(seed, kept[i]).brdf;
    let start = Instant::now();
    let basis = build_basis_from(&source, &spec, &|_| {});
    log(&format!(
        "fold {fold}: basis of {} materials built in {:.0} s",
        options.basis_materials,
        start.elapsed().as_secs_f64()
    ));
    if let Err(e) = cache.store(&spec, &basis) {
        log(&format!("fold {fold}: basis not cached ({e})"));
    }
    Ok(Arc::new(basis))
}

/// The bin changes of a perfect painter's renders of `truth` under each (paint, view set)
/// arrangement.
fn paint_view_sets(
    truth: &crate::table::SymTable,
    arrangements: &[(PaintRange, &[GBuffer])],
) -> Vec<Vec<BinChange>> {
    arrangements
        .iter()
        .map(|&(paint, set)| {
            let mut table = SparseTable::new(Policy::Mean);
            let mut changes = Vec::new();
            for (view, gbuffer) in set.iter().enumerate() {
                let render = render_table(gbuffer, truth);
                let painting = match paint {
                    PaintRange::Hdr => render,
                    PaintRange::Ldr => super::ldr_round_trip(&render),
                };
                samples_from_image_in(gbuffer, &painting, paint)
                    .insert_into(view as u32, &mut table, &mut changes)
                    .expect("a render of a physical table is finite and non-negative");
            }
            changes
        })
        .collect()
}

/// Runs the cross-validation; `log` hears of each fold and material.
pub fn calibrate(options: &CalibrateOptions, log: &dyn Fn(&str)) -> Result<Calibration> {
    let started = Instant::now();
    let sets = view_sets();
    let object = Object::builtin(crate::scene::BuiltinShape::Sphere);
    let gbuffers: Vec<Vec<GBuffer>> = sets
        .iter()
        .map(|set| {
            set.iter()
                .map(|&(elevation_deg, azimuth_deg, yaw_deg, pitch_deg)| {
                    let scene = Scene {
                        resolution: options.resolution,
                        light: LightSettings {
                            elevation_deg,
                            azimuth_deg,
                        },
                        camera: CameraSettings {
                            yaw_deg,
                            pitch_deg,
                            ..CameraSettings::default()
                        },
                        ..Scene::default()
                    };
                    GBuffer::build(&scene, &object)
                })
                .collect()
        })
        .collect();
    // Paint-major, so that each paint's sets still come in (one view, three views) pairs.
    let arrangements: Vec<(PaintRange, &[GBuffer])> = options
        .paints
        .iter()
        .flat_map(|&paint| gbuffers.iter().map(move |set| (paint, set.as_slice())))
        .collect();
    let arranged_sets: Vec<(PaintRange, usize)> = arrangements
        .iter()
        .map(|&(paint, set)| (paint, set.len()))
        .collect();
    // errors[candidate][case][arrangement] = (relative RMSE, log RMSE)
    let mut errors: Vec<Vec<Vec<(f64, f64)>>> = vec![Vec::new(); options.candidates.len()];
    let mut folds = Vec::new();
    for fold in 0..options.folds {
        let out = left_out_families(fold, options.folds);
        let basis = fold_basis(options, fold, &out, log)?;
        let tests = indices_where(|f| out.contains(&f), options.tests_per_fold);
        let mut labels = Vec::new();
        for index in tests {
            let m = material(CALIBRATION_SEED, index);
            let truth = tabulate(&*m.brdf);
            let painted = paint_view_sets(&truth, &arrangements);
            let per_candidate: Vec<Vec<(f64, f64)>> = options
                .candidates
                .par_iter()
                .map(|c| {
                    painted
                        .iter()
                        .map(|changes| {
                            let mut solver = Solver::with_model(
                                basis.clone(),
                                Regularization::Prior { alpha: c.alpha },
                                c.model,
                            );
                            solver.apply_all(changes);
                            solver.refit_prior_mean();
                            let solution = solver.solve();
                            let estimate = Reconstruction::with_knots(
                                basis.clone(),
                                &solution.coefficients,
                                c.model.knots,
                            )
                            .with_reference(solution.reference)
                            .materialize();
                            let e = table_errors(&truth, &estimate);
                            (e.relative_rmse, e.log_rmse)
                        })
                        .collect()
                })
                .collect();
            log(&format!("fold {fold}: {} ({})", m.family.name(), m.label));
            for (c, these) in per_candidate.iter().enumerate() {
                log(&format!(
                    "  candidate {c}: relative RMSE {}",
                    case_figures(these, &arranged_sets)
                ));
            }
            for (all, these) in errors.iter_mut().zip(per_candidate) {
                all.push(these);
            }
            labels.push(format!("{}: {}", m.family.name(), m.label));
        }
        folds.push((fold, out.iter().map(|f| f.name()).collect(), labels));
    }
    let mut scores: Vec<CandidateScore> = options
        .candidates
        .iter()
        .zip(&errors)
        .map(|(&candidate, cases)| score(candidate, cases, &arranged_sets))
        .collect();
    scores.sort_by(|a, b| {
        a.geometric_mean_relative_rmse
            .total_cmp(&b.geometric_mean_relative_rmse)
    });
    Ok(Calibration {
        scores,
        folds,
        seconds: started.elapsed().as_secs_f64(),
    })
}

/// One case's relative RMSE per arrangement, "hdr 1v 0.123 → 3v 0.101, …", so that a log
/// shows which materials an added view hurt.
fn case_figures(case: &[(f64, f64)], arrangements: &[(PaintRange, usize)]) -> String {
    case.iter()
        .zip(arrangements)
        .map(|(&(rel, _), &(paint, views))| format!("{} {views}v {rel:.3}", paint.name()))
        .collect::<Vec<_>>()
        .join(", ")
}

/// `arrangements`: the paint and the number of views of each case's entries.
fn score(
    candidate: Candidate,
    cases: &[Vec<(f64, f64)>],
    arrangements: &[(PaintRange, usize)],
) -> CandidateScore {
    let (mut logs, mut ln_sum, mut n) = (vec![], 0.0, 0.0f64);
    // By (LDR, three views).
    let mut by_kind: [[Vec<f64>; 2]; 2] = Default::default();
    let mut views_hurt = 0;
    let mut comparisons = 0;
    for case in cases {
        for (&(paint, views), &(rel, log)) in arrangements.iter().zip(case) {
            // A table that blew up counts as 3: it ranks last without drowning the mean.
            let rel = if rel.is_finite() { rel.min(3.0) } else { 3.0 };
            ln_sum += rel.max(1e-6).ln();
            n += 1.0;
            logs.push(log);
            by_kind[usize::from(paint == PaintRange::Ldr)][usize::from(views > 1)].push(rel);
        }
        // Sets come in (one view, the same first view plus two) pairs.
        for pair in case.chunks(2) {
            if let [(first, _), (more, _)] = pair {
                comparisons += 1;
                views_hurt += usize::from(*more > 1.1 * *first);
            }
        }
    }
    let mean = |v: &[f64]| {
        if v.is_empty() {
            f64::NAN
        } else {
            v.iter().sum::<f64>() / v.len() as f64
        }
    };
    let [[hdr_one, hdr_three], [ldr_one, ldr_three]] = &mut by_kind;
    CandidateScore {
        candidate,
        geometric_mean_relative_rmse: (ln_sum / n.max(1.0)).exp(),
        mean_relative_rmse_1view: mean(hdr_one),
        median_relative_rmse_1view: median(hdr_one),
        mean_relative_rmse_3view: mean(hdr_three),
        median_relative_rmse_3view: median(hdr_three),
        mean_relative_rmse_1view_ldr: mean(ldr_one),
        median_relative_rmse_1view_ldr: median(ldr_one),
        mean_relative_rmse_3view_ldr: mean(ldr_three),
        median_relative_rmse_3view_ldr: median(ldr_three),
        mean_log_rmse: mean(&logs),
        views_hurt,
        comparisons,
    }
}

fn median(v: &mut [f64]) -> f64 {
    if v.is_empty() {
        return f64::NAN;
    }
    v.sort_by(f64::total_cmp);
    let n = v.len();
    if n % 2 == 1 {
        v[n / 2]
    } else {
        0.5 * (v[n / 2 - 1] + v[n / 2])
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_family_is_left_out_exactly_once() {
        let folds = 4;
        let mut seen: Vec<Family> = (0..folds)
            .flat_map(|f| left_out_families(f, folds))
            .collect();
        assert_eq!(seen.len(), Family::ALL.len());
        seen.sort_by_key(|f| f.name());
        seen.dedup();
        assert_eq!(seen.len(), Family::ALL.len());
    }

    #[test]
    fn a_fold_tests_only_families_its_basis_never_saw() {
        let out = left_out_families(1, 4);
        let tests = indices_where(|f| out.contains(&f), 6);
        let kept = indices_where(|f| !out.contains(&f), 50);
        assert_eq!(tests.len(), 6);
        assert!(tests.iter().all(|&i| out.contains(&family_of(i))));
        assert!(kept.iter().all(|&i| !out.contains(&family_of(i))));
    }

    #[test]
    fn view_sets_pair_one_view_with_three_that_start_from_it() {
        let sets = view_sets();
        for pair in sets.chunks(2) {
            assert_eq!((pair[0].len(), pair[1].len()), (1, 3));
            assert_eq!(pair[0][0], pair[1][0]);
        }
    }

    /// Cross-validation must tell a sane prior from absurd ones: one so weak the solve
    /// extrapolates freely, one so strong the painting is ignored.
    #[test]
    fn cross_validation_ranks_a_sane_prior_above_absurd_ones() {
        let dir = tempfile::tempdir().unwrap();
        let sane = Candidate {
            alpha: 10.0,
            model: PriorModel::CALIBRATED,
        };
        let options = CalibrateOptions {
            cache: BasisCache::at(dir.path().to_path_buf()),
            folds: 2,
            basis_materials: 30,
            components: 8,
            tests_per_fold: 1,
            resolution: 64,
            paints: vec![PaintRange::Hdr, PaintRange::Ldr],
            candidates: vec![
                Candidate { alpha: 1e4, ..sane },
                sane,
                Candidate {
                    alpha: 1e-5,
                    ..sane
                },
            ],
        };
        let c = calibrate(&options, &|_| {}).unwrap();
        assert_eq!(c.folds.len(), 2);
        assert_eq!(c.scores.len(), 3);
        assert_eq!(c.scores[0].candidate, sane, "{:#?}", c.scores);
        for s in &c.scores {
            // 2 folds × 1 material × 2 arrangements of lights × 2 paints.
            assert_eq!(s.comparisons, 2 * 2 * 2);
            assert!(s.geometric_mean_relative_rmse.is_finite());
            assert!(s.mean_relative_rmse_1view_ldr.is_finite());
            assert!(s.median_relative_rmse_3view_ldr.is_finite());
        }
    }
}
