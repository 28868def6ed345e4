//! A reference fitted to the paint itself: Lambert (or Oren–Nayar) + a microfacet lobe (GGX, or
//! Beckmann where [`super::PriorMean::Fitted`] asks for it) fitted to the painted bins
//! ([`super::analytic_fit`]), tabulated, and used as the table the basis then corrects.
//!
//! **Why.** Centred on the database's mean material, the prior fills the unpainted part of
//! the table with that mean plus whatever the components' correlations carry over from the
//! painted part; on materials unlike the database's mean that carried-over part overshoots,
//! and it is where almost all of the error lives (../shared/findings). A physically shaped
//! model fitted to the same bins extrapolates the way materials do (a lobe keeps its width
//! and its Fresnel rise), so the solve then only paints the differences on top of it.
//!
//! **Why not its projection.** The first version projected the fit onto the K components
//! and centred the prior there. K components cannot hold a narrow lobe or a dark diffuse
//! floor: the projection smeared the fit exactly where it was meant to help, and a second
//! view could make a two-lobe metal worse. Kept as a per-entry reference instead,
//! ρ̂ = unmap(map(F) + Σ_k u_k x_k), the fit keeps its shape and the K coefficients describe
//! only how the paint departs from it (measured in `PriorMean::FITTED`'s notes).
//!
//! **Cost.** A fit takes a few hundred milliseconds, too slow for the live loop's solve, so
//! it is a separate step: [`super::Solver::mean_fit_request`] copies what the fit needs,
//! [`MeanFitRequest::run`] runs anywhere (the worker runs it on its own thread while paint
//! settles), and [`super::Solver::install_fitted_mean`] takes the answer back, deciding by
//! the evidence whether the solve measures the paint from it. The command line does the three
//! at once ([`super::Solver::refit_prior_mean`]). Everything is deterministic, so the app and
//! the command line reach the same reference from the same bins.

use super::analytic_fit::{
    FitOptions, LambertMicrofacet, PaintedBin, Prepared, fit_lambert_microfacet_painted,
};
use super::prior::PriorMean;
use crate::basis::Basis;
use crate::materials::tabulate;
use crate::table::{PAIRS, PairIndex};
use rayon::prelude::*;
use std::sync::Arc;

/// How far (in nats of the mapped domain) a fitted reference may lie from the database's
/// mean: e^40 is far beyond any material, and keeps every later exp finite in f32. (Bounding
/// it to the database's range plus 1 nat changed no figure of the pipeline tests: the fits'
/// lobes stay inside what the database spans.)
const OFFSET_LIMIT: f32 = 40.0;

/// What a fit of the reference needs, copied out of a solver.
#[derive(Clone, Debug)]
pub struct MeanFitRequest {
    /// The solver's generation of painted bins this request was made for.
    pub generation: u64,
    pub(super) bins: Vec<PaintedBin>,
    pub(super) basis: Arc<Basis>,
    /// The lobe shapes the fit tries ([`super::PriorMean::Fitted`]'s choice).
    pub(super) options: FitOptions,
}

/// A fitted reference, ready to install.
#[derive(Clone, Debug)]
pub struct FittedMean {
    /// The generation of painted bins it was fitted to.
    pub generation: u64,
    pub reference: Arc<FittedReference>,
}

/// A fitted model as a table of offsets from the basis's mean in the mapped domain: per pair
/// and channel, map(F_p) − mean_p. The reconstruction adds it to what the coefficients give;
/// the solver subtracts it from each painted bin.
pub struct FittedReference {
    model: LambertMicrofacet,
    /// The basis whose map and mean the offsets are measured in.
    basis: Arc<Basis>,
    offsets: Vec<[f32; 3]>,
}

impl std::fmt::Debug for FittedReference {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("FittedReference")
            .field("model", &self.model)
            .finish_non_exhaustive()
    }
}

/// Two references are the same when they tabulate the same model on the same basis.
impl PartialEq for FittedReference {
    fn eq(&self, other: &Self) -> bool {
        self.model == other.model && Arc::ptr_eq(&self.basis, &other.basis)
    }
}

impl FittedReference {
    /// Tabulates `model` on `basis`'s map.
    pub fn new(basis: Arc<Basis>, model: LambertMicrofacet) -> Self {
        let table = tabulate(&Prepared::new(model));
        let offsets = table
            .pairs()
            .par_iter()
            .enumerate()
            .with_min_len(4096)
            .map(|(p, rho)| {
                let pair = PairIndex::from_index(p);
                rho.map(|v| {
                    // Unclamped to the database's range: the fit may leave it, which is the
                    // point of keeping it per entry.
                    let offset = basis.mapped_from_mean(pair, v as f64) as f32;
                    if offset.is_finite() {
                        offset.clamp(-OFFSET_LIMIT, OFFSET_LIMIT)
                    } else {
                        0.0
                    }
                })
            })
            .collect();
        Self {
            model,
            basis,
            offsets,
        }
    }

    pub fn model(&self) -> &LambertMicrofacet {
        &self.model
    }

    pub fn basis(&self) -> &Arc<Basis> {
        &self.basis
    }

    /// map(F_p) − mean_p for each channel.
    #[inline]
    pub fn offset(&self, pair: PairIndex) -> [f32; 3] {
        self.offsets[pair.index()]
    }

    /// Every pair's offsets, in pair order ([`PAIRS`] entries).
    pub fn offsets(&self) -> &[[f32; 3]] {
        debug_assert_eq!(self.offsets.len(), PAIRS);
        &self.offsets
    }
}

impl MeanFitRequest {
    /// Painted bins the fit sees.
    pub fn bins(&self) -> usize {
        self.bins.len()
    }

    /// Fits the model and tabulates it. Deterministic for given bins, whatever the threads.
    pub fn run(self) -> FittedMean {
        let fit = fit_lambert_microfacet_painted(&self.bins, &self.options);
        FittedMean {
            generation: self.generation,
            reference: Arc::new(FittedReference::new(self.basis, fit.model)),
        }
    }
}

/// The fit's options for the prior's mean `mean`: which lobe shapes it tries.
pub(super) fn fit_options(mean: PriorMean) -> FitOptions {
    match mean {
        PriorMean::Fitted {
            beckmann_margin,
            coat_margin,
            edge_margin,
            haze_margin,
            rough_margin,
            grazing_weight,
            dielectric_margin,
            phong_margin,
            gtr_margin,
            cavity_margin,
            ..
        } => FitOptions {
            beckmann_margin,
            coat_margin,
            edge_margin,
            haze_margin,
            rough_margin,
            grazing_weight,
            dielectric_margin,
            phong_margin,
            gtr_margin,
            cavity_margin,
            ..Default::default()
        },
        PriorMean::Database => FitOptions::default(),
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::basis::build::{SMALL_TEST_SPEC, build_basis, small_test_basis};
    use crate::materials::models::{Distribution, Masking};
    use crate::solver::{BinChange, EXACT, PriorModel, Reconstruction, Regularization, Solver};

    fn basis() -> Arc<Basis> {
        small_test_basis()
    }

    /// An orange plastic: inside the fit's own family, so a fit can recover it.
    fn plastic() -> LambertMicrofacet {
        LambertMicrofacet {
            albedo: [0.6, 0.3, 0.1],
            sigma: 0.0,
            f0: [0.04; 3],
            specular: 1.0,
            distribution: Distribution::Ggx,
            alpha_x: 0.2,
            alpha_y: 0.2,
            rotation: 0.0,
            coat: None,
            haze: None,
            edge: None,
            masking: Masking::Smith,
        }
    }

    /// Every 211th pair of the table, painted exactly from `model`.
    fn painted(model: &LambertMicrofacet) -> Vec<BinChange> {
        let table = tabulate(model);
        (0..PAIRS)
            .step_by(211)
            .map(|p| {
                let pair = PairIndex::from_index(p);
                BinChange::observed(pair, table.pairs()[p].map(f64::from), EXACT)
            })
            .collect()
    }

    /// The offsets are the model's table in the basis's mapped domain: with no correction on
    /// top, the reconstruction measured from the reference is the model's own table.
    #[test]
    fn a_reference_with_no_correction_is_its_models_table() {
        let model = plastic();
        let reference = Arc::new(FittedReference::new(basis(), model));
        assert_eq!(reference.offsets().len(), PAIRS);
        let truth = tabulate(&model);
        let k = basis().components();
        let rebuilt = Reconstruction::new(basis(), &vec![[0.0; 3]; k])
            .with_reference(Some(reference.clone()))
            .materialize();
        for p in (0..PAIRS).step_by(97) {
            let pair = PairIndex::from_index(p);
            assert_eq!(reference.offset(pair), reference.offsets()[p]);
            for c in 0..3 {
                let (want, got) = (truth.pairs()[p][c], rebuilt.pairs()[p][c]);
                assert!(
                    (got - want).abs() <= 1e-4 * want.abs() + 1e-7,
                    "pair {p} channel {c}: {got} against the model's {want}"
                );
            }
        }
    }

    /// Two references are equal only for the same model on the same basis (the same `Arc`:
    /// the offsets are measured from that basis's mean).
    #[test]
    fn references_are_equal_for_one_model_on_one_basis() {
        let same = FittedReference::new(basis(), plastic());
        assert_eq!(same, FittedReference::new(basis(), plastic()));
        let rougher = LambertMicrofacet {
            alpha_x: 0.3,
            ..plastic()
        };
        assert_ne!(same, FittedReference::new(basis(), rougher));
        let other_basis = Arc::new(build_basis(&SMALL_TEST_SPEC, &|_| {}));
        assert_ne!(same, FittedReference::new(other_basis, plastic()));
    }

    /// The debug text names the model, and not the million offsets.
    #[test]
    fn a_reference_debugs_as_its_model() {
        let text = format!("{:?}", FittedReference::new(basis(), plastic()));
        assert!(text.starts_with("FittedReference"), "{text}");
        assert!(text.contains("alpha_x: 0.2"), "{text}");
        assert!(!text.contains("offsets"), "{text}");
    }

    /// A request carries every painted bin and the solver's generation, and its fit recovers
    /// a model of its own family.
    #[test]
    fn a_request_fits_the_painted_bins_it_copied() {
        let mut solver = Solver::with_model(basis(), Regularization::Auto, PriorModel::CALIBRATED);
        let changes = painted(&plastic());
        solver.apply_all(&changes);
        let request = solver.mean_fit_request().expect("a fit is due");
        assert_eq!(request.bins(), changes.len());
        let generation = request.generation;
        let fitted = request.run();
        assert_eq!(fitted.generation, generation);
        let model = *fitted.reference.model();
        let truth = plastic();
        assert!(
            (model.alpha_x - truth.alpha_x).abs() < 0.01
                && (model.alpha_y - truth.alpha_y).abs() < 0.01,
            "{model:?}"
        );
        for c in 0..3 {
            assert!(
                (model.albedo[c] - truth.albedo[c]).abs() < 0.01,
                "{model:?}"
            );
            assert!(
                (model.specular * model.f0[c] - truth.f0[c]).abs() < 0.004,
                "{model:?}"
            );
        }
        assert!(Arc::ptr_eq(fitted.reference.basis(), &basis()));
    }

    /// The fit tries the lobe shapes the prior's mean names, and GGX alone for the database's
    /// mean (which fits nothing but the analytic baseline).
    #[test]
    fn the_fit_tries_the_shapes_the_prior_mean_names() {
        let mean = PriorMean::Fitted {
            margin_nats: 3.0,
            beckmann_margin: Some(1.5),
            coat_margin: Some(2.0),
            edge_margin: Some(1.2),
            haze_margin: Some(1.3),
            rough_margin: Some(1.4),
            grazing_weight: Some(0.9),
            dielectric_margin: Some(1.6),
            phong_margin: Some(1.7),
            gtr_margin: Some(1.8),
            closer_margin: None,
            cavity_margin: None,
        };
        let options = fit_options(mean);
        assert_eq!(options.beckmann_margin, Some(1.5));
        assert_eq!(options.coat_margin, Some(2.0));
        assert_eq!(options.edge_margin, Some(1.2));
        assert_eq!(options.haze_margin, Some(1.3));
        assert_eq!(options.rough_margin, Some(1.4));
        assert_eq!(options.grazing_weight, Some(0.9));
        assert_eq!(options.dielectric_margin, Some(1.6));
        assert_eq!(options.phong_margin, Some(1.7));
        assert_eq!(options.gtr_margin, Some(1.8));
        assert_eq!(options.finalists, FitOptions::default().finalists);
        assert_eq!(fit_options(PriorMean::Database), FitOptions::default());
        assert_eq!(fit_options(PriorMean::FITTED).beckmann_margin, Some(1.0));
    }
}
