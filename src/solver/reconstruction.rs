//! The reconstructed BRDF: evaluated lazily, entry by entry, for what a view needs, or
//! materialised in parallel as a full table for export.

use super::bands::{BANDS, DEFAULT_KNOTS, KnotSpacing, pair_bands_spaced};
use super::fitted_mean::FittedReference;
use crate::basis::{Basis, MAP_EPSILON, RANGE_MARGIN, cos_weight_polar};
use crate::table::{DIRECTIONS, DirIndex, PHI_BINS, PairIndex, Rgb, SymTable, pair_index};
use rayon::prelude::*;
use std::sync::Arc;

/// A basis and its coefficients: ρ = unmap(clamp(mean + Σ_k u_k x_k(θ_d)) + o), clamped to
/// the range the database spans so that one stray sample can't blow a highlight up. x(θ_d) is
/// one set of K coefficients (the global prior) or the blend of the two [`BANDS`] sets around
/// the pair's θ_d (the localised prior, [`super::bands`]); o is 0, or a fitted reference's
/// offset map(F) − mean when the coefficients were measured from one
/// ([`super::fitted_mean`]).
#[derive(Clone, Debug)]
pub struct Reconstruction {
    basis: Arc<Basis>,
    /// Coefficient sets: 1 or [`BANDS`].
    bands: usize,
    /// Where the sets' knots sit over θ_d (when `bands` > 1).
    knots: KnotSpacing,
    /// Coefficients by channel, bands × K each (band-major), in f32 for the evaluation loops.
    coefficients: [Vec<f32>; 3],
    /// The fitted reference the coefficients are measured from, if any.
    reference: Option<Arc<FittedReference>>,
}

impl Reconstruction {
    /// The reconstruction for coefficients `x`: K rows of R, G, B (one set), or [`BANDS`] × K
    /// (a solution of the localised prior, band-major).
    pub fn new(basis: Arc<Basis>, x: &[[f64; 3]]) -> Self {
        Self::with_knots(basis, x, DEFAULT_KNOTS)
    }

    /// As [`Self::new`], for a solution of a prior whose knots sit at `knots` (the default
    /// prior's are [`DEFAULT_KNOTS`]; the calibration scores others).
    pub fn with_knots(basis: Arc<Basis>, x: &[[f64; 3]], knots: KnotSpacing) -> Self {
        let k = basis.components();
        let bands = x.len() / k.max(1);
        assert!(
            bands * k == x.len() && (bands == 1 || bands == BANDS),
            "K or {BANDS}·K coefficient rows, got {} for K = {k}",
            x.len()
        );
        let coefficients = std::array::from_fn(|c| x.iter().map(|row| row[c] as f32).collect());
        Self {
            basis,
            bands,
            knots,
            coefficients,
            reference: None,
        }
    }

    /// The same coefficients measured from `reference` (`None`: the basis's mean). A
    /// reference tabulated on another basis is ignored: its offsets mean nothing here.
    pub fn with_reference(mut self, reference: Option<Arc<FittedReference>>) -> Self {
        debug_assert!(
            reference
                .as_ref()
                .is_none_or(|r| Arc::ptr_eq(r.basis(), &self.basis)),
            "a reference tabulated on another basis"
        );
        self.reference = reference.filter(|r| Arc::ptr_eq(r.basis(), &self.basis));
        self
    }

    /// The fitted reference the coefficients are measured from, if any.
    pub fn reference(&self) -> Option<&Arc<FittedReference>> {
        self.reference.as_ref()
    }

    /// Coefficient sets: 1 (global) or [`BANDS`] (localised).
    pub fn bands(&self) -> usize {
        self.bands
    }

    /// The database's mean material (all coefficients zero): what an empty painting gives.
    pub fn mean_material(basis: Arc<Basis>) -> Self {
        let k = basis.components();
        Self::new(basis, &vec![[0.0; 3]; k])
    }

    pub fn basis(&self) -> &Arc<Basis> {
        &self.basis
    }

    /// ρ of the unordered pair `pair`.
    #[inline]
    pub fn eval_pair(&self, pair: PairIndex) -> Rgb {
        let (lo, hi) = crate::table::pair_directions(pair);
        self.evaluator()
            .eval(pair.index(), lo as usize / PHI_BINS, hi as usize / PHI_BINS)
    }

    /// ρ(d_l, d_v).
    #[inline]
    pub fn eval(&self, d_l: DirIndex, d_v: DirIndex) -> Rgb {
        let pair = pair_index(d_l, d_v).index();
        self.evaluator()
            .eval(pair, d_l as usize / PHI_BINS, d_v as usize / PHI_BINS)
    }

    /// Evaluates only the pairs a view asks for, in parallel for large requests.
    pub fn eval_pairs(&self, pairs: &[PairIndex], out: &mut Vec<Rgb>) {
        let evaluator = self.evaluator();
        let one = |&p: &PairIndex| {
            let (lo, hi) = crate::table::pair_directions(p);
            evaluator.eval(p.index(), lo as usize / PHI_BINS, hi as usize / PHI_BINS)
        };
        out.clear();
        if pairs.len() < 16_384 {
            out.extend(pairs.iter().map(one));
        } else {
            pairs
                .par_iter()
                .with_min_len(4096)
                .map(one)
                .collect_into_vec(out);
        }
    }

    /// The slices one evaluation reads, looked up once per batch rather than once per entry.
    fn evaluator(&self) -> Evaluator<'_> {
        Evaluator {
            k: self.basis.components(),
            bands: (self.bands > 1).then(|| pair_bands_spaced(self.knots)),
            rows: self.basis.rows(),
            means: self.basis.means(),
            references: self.basis.references(),
            lowers: self.basis.lowers(),
            uppers: self.basis.uppers(),
            offsets: self.reference.as_ref().map(|r| r.offsets()),
            coefficients: &self.coefficients,
        }
    }

    /// The full table, in parallel. Each pair is evaluated once: reciprocal by construction.
    pub fn materialize(&self) -> SymTable {
        let mut values = vec![[0f32; 3]; crate::table::PAIRS];
        // Split the storage into the runs of one `hi` each (pairs (0..=hi, hi)).
        let mut runs: Vec<(usize, &mut [Rgb])> = Vec::with_capacity(DIRECTIONS);
        let mut rest: &mut [Rgb] = &mut values;
        for hi in 0..DIRECTIONS {
            let (run, tail) = rest.split_at_mut(hi + 1);
            runs.push((hi, run));
            rest = tail;
        }
        let evaluator = self.evaluator();
        runs.into_par_iter().with_min_len(8).for_each(|(hi, run)| {
            let base = hi * (hi + 1) / 2;
            let t_hi = hi / PHI_BINS;
            for (lo, out) in run.iter_mut().enumerate() {
                *out = evaluator.eval(base + lo, lo / PHI_BINS, t_hi);
            }
        });
        SymTable::from_pairs(values).expect("PAIRS values")
    }
}

/// Borrowed basis arrays and coefficients for a run of evaluations.
struct Evaluator<'a> {
    k: usize,
    /// Per-pair band weights when there is more than one coefficient set.
    bands: Option<&'a [super::bands::BandWeights]>,
    rows: &'a [f32],
    means: &'a [f32],
    references: &'a [f32],
    lowers: &'a [f32],
    uppers: &'a [f32],
    /// A fitted reference's map(F) − mean per pair, if any.
    offsets: Option<&'a [[f32; 3]]>,
    coefficients: &'a [Vec<f32>; 3],
}

impl Evaluator<'_> {
    /// ρ of pair `pair` whose directions lie in polar bins `t_l` and `t_v`.
    ///
    /// The pair is a raw storage position, not a [`PairIndex`]: [`Reconstruction::materialize`]
    /// walks every position in order, and a checked [`PairIndex`] per entry would add a bounds
    /// assertion to its innermost loop for nothing.
    #[inline]
    fn eval(&self, pair: usize, t_l: usize, t_v: usize) -> Rgb {
        let k = self.k;
        let row = &self.rows[pair * k..(pair + 1) * k];
        let [xr, xg, xb] = self.coefficients;
        let dot = |set: usize| {
            let (xr, xg, xb) = (
                &xr[set * k..(set + 1) * k],
                &xg[set * k..(set + 1) * k],
                &xb[set * k..(set + 1) * k],
            );
            let (mut r, mut g, mut b) = (0f32, 0f32, 0f32);
            for (i, &u) in row.iter().enumerate() {
                r += u * xr[i];
                g += u * xg[i];
                b += u * xb[i];
            }
            [r, g, b]
        };
        let [r, g, b] = match self.bands {
            None => dot(0),
            Some(bands) => {
                let w = bands[pair];
                let lower = dot(w.lower as usize);
                if w.frac == 0.0 {
                    lower
                } else {
                    let upper = dot(w.lower as usize + 1);
                    std::array::from_fn(|c| lower[c] + w.frac * (upper[c] - lower[c]))
                }
            }
        };
        let mean = self.means[pair];
        let reference = self.references[pair] + MAP_EPSILON as f32;
        let lo = self.lowers[pair] - RANGE_MARGIN;
        let hi = self.uppers[pair] + RANGE_MARGIN;
        let inv_c = (1.0 / cos_weight_polar(t_l, t_v)) as f32;
        let offset = self.offsets.map_or([0.0; 3], |o| o[pair]);
        let unmap = |d: f32, offset: f32| {
            // Clamping keeps ρ finite (the offset is bounded); max(0) also maps a NaN from
            // bad coefficients to 0.
            let m = (mean + d).clamp(lo, hi) + offset;
            ((m.exp() * reference - MAP_EPSILON as f32) * inv_c).max(0.0)
        };
        [
            unmap(r, offset[0]),
            unmap(g, offset[1]),
            unmap(b, offset[2]),
        ]
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::basis::build::small_test_basis;
    use crate::materials::models::{Distribution, Masking};
    use crate::solver::analytic_fit::LambertMicrofacet;
    use crate::table::PAIRS;

    /// Coefficients that differ per band, per channel and per component, so that a wrong
    /// band, channel or component shows.
    fn banded_coefficients(k: usize) -> Vec<[f64; 3]> {
        (0..BANDS * k)
            .map(|i| {
                let (band, j) = ((i / k) as f64, (i % k) as f64);
                [
                    0.3 * (band - 2.0) + 0.1 * j,
                    -0.2 * band + 0.05 * j,
                    0.1 * (band * j).sin(),
                ]
            })
            .collect()
    }

    fn reference(basis: &Arc<Basis>) -> Arc<FittedReference> {
        Arc::new(FittedReference::new(
            basis.clone(),
            LambertMicrofacet {
                albedo: [0.5, 0.3, 0.2],
                sigma: 0.0,
                f0: [0.05; 3],
                specular: 1.0,
                distribution: Distribution::Ggx,
                alpha_x: 0.3,
                alpha_y: 0.3,
                rotation: 0.0,
                coat: None,
                haze: None,
                edge: None,
                masking: Masking::Smith,
            },
        ))
    }

    /// Pairs from every polar bin of both directions, in a scattered order.
    fn sample_pairs() -> Vec<PairIndex> {
        (0..PAIRS)
            .step_by(4099)
            .map(PairIndex::from_index)
            .collect()
    }

    /// A view's entries (one at a time, by pair or by its two directions in either order,
    /// or a batch small or large enough to run in parallel) are the exported table's, for a
    /// localised solution measured from a fitted reference. Each lookup finds the polar bins
    /// of its directions itself, and the cosine weight it divides by depends on them.
    #[test]
    fn every_way_of_evaluating_an_entry_gives_the_tables_value() {
        let basis = small_test_basis();
        let x = banded_coefficients(basis.components());
        let reconstruction =
            Reconstruction::new(basis.clone(), &x).with_reference(Some(reference(&basis)));
        let table = reconstruction.materialize();
        let pairs = sample_pairs();
        let mut batch = Vec::new();
        reconstruction.eval_pairs(&pairs, &mut batch);
        assert_eq!(batch.len(), pairs.len());
        for (&pair, &batched) in pairs.iter().zip(&batch) {
            let want = table.pairs()[pair.index()];
            let (lo, hi) = crate::table::pair_directions(pair);
            assert_eq!(reconstruction.eval_pair(pair), want, "{pair:?}");
            assert_eq!(reconstruction.eval(lo, hi), want, "{pair:?}");
            assert_eq!(reconstruction.eval(hi, lo), want, "{pair:?}");
            assert_eq!(batched, want, "{pair:?}");
        }
        // A request as large as a whole view's is evaluated in parallel, in order.
        let many: Vec<PairIndex> = (0..PAIRS)
            .rev()
            .step_by(37)
            .map(PairIndex::from_index)
            .collect();
        assert!(many.len() > 20_000);
        reconstruction.eval_pairs(&many, &mut batch);
        assert_eq!(batch.len(), many.len());
        for (&pair, &batched) in many.iter().zip(&batch) {
            assert_eq!(batched, table.pairs()[pair.index()], "{pair:?}");
        }
    }

    /// An entry is the basis's mean plus its rows times the coefficients, clamped to the range
    /// the database spans and unmapped (written out here from the basis's arrays in f64).
    #[test]
    fn an_entry_is_the_unmapped_sum_of_the_mean_and_the_weighted_rows() {
        let basis = small_test_basis();
        let k = basis.components();
        let mut clamped = 0;
        // Small coefficients stay inside the range; large ones reach its ends.
        for scale in [1.0, 5000.0] {
            let x: Vec<[f64; 3]> = (0..k)
                .map(|j| [0.4 - 0.1 * j as f64, 0.2 * j as f64, -0.3].map(|v| v * scale))
                .collect();
            let reconstruction = Reconstruction::new(basis.clone(), &x);
            for pair in sample_pairs() {
                let p = pair.index();
                let (lo, hi) = crate::table::pair_directions(pair);
                let c = cos_weight_polar(lo as usize / PHI_BINS, hi as usize / PHI_BINS);
                let got = reconstruction.eval_pair(pair);
                for ch in 0..3 {
                    let sum: f64 = (0..k)
                        .map(|j| f64::from(basis.rows()[p * k + j]) * x[j][ch])
                        .sum();
                    let range = f64::from(basis.lowers()[p] - RANGE_MARGIN)
                        ..=f64::from(basis.uppers()[p] + RANGE_MARGIN);
                    let mapped = f64::from(basis.means()[p]) + sum;
                    clamped += usize::from(!range.contains(&mapped));
                    let mapped = mapped.clamp(*range.start(), *range.end());
                    let reference = f64::from(basis.references()[p]) + MAP_EPSILON;
                    let want = ((mapped.exp() * reference - MAP_EPSILON) / c).max(0.0);
                    assert!(
                        (f64::from(got[ch]) - want).abs() <= 1e-4 * want + 1e-7,
                        "{pair:?} channel {ch}: {} against {want}",
                        got[ch]
                    );
                }
            }
        }
        assert!(clamped > 0, "no sampled entry reaches the database's range");
    }

    /// A localised solution at a pair is the global solution whose coefficients are the two
    /// bands' around the pair's θ_d, blended by the pair's weight.
    #[test]
    fn a_localised_solution_blends_the_two_bands_around_each_pair() {
        let basis = small_test_basis();
        let k = basis.components();
        let x = banded_coefficients(k);
        let localised = Reconstruction::new(basis.clone(), &x);
        let weights = pair_bands_spaced(DEFAULT_KNOTS);
        let mut blended_somewhere = false;
        for pair in sample_pairs() {
            let w = weights[pair.index()];
            let band = |b: usize, j: usize| x[(b.min(BANDS - 1)) * k + j];
            let blend: Vec<[f64; 3]> = (0..k)
                .map(|j| {
                    let (lower, upper) = (band(w.lower as usize, j), band(w.lower as usize + 1, j));
                    std::array::from_fn(|c| lower[c] + f64::from(w.frac) * (upper[c] - lower[c]))
                })
                .collect();
            blended_somewhere |= w.frac > 0.05 && w.frac < 0.95;
            let want = Reconstruction::new(basis.clone(), &blend).eval_pair(pair);
            let got = localised.eval_pair(pair);
            for c in 0..3 {
                assert!(
                    (got[c] - want[c]).abs() <= 1e-4 * want[c].abs() + 1e-6,
                    "{pair:?} channel {c}: {got:?} against the blend's {want:?} ({w:?})"
                );
            }
        }
        assert!(blended_somewhere, "no sampled pair lies between two knots");
    }

    /// What a reconstruction reports of itself: its coefficient sets and its reference.
    #[test]
    fn a_reconstruction_reports_its_bands_and_reference() {
        let basis = small_test_basis();
        let k = basis.components();
        let global = Reconstruction::new(basis.clone(), &vec![[0.1; 3]; k]);
        assert_eq!(global.bands(), 1);
        assert!(global.reference().is_none());
        let localised = Reconstruction::new(basis.clone(), &banded_coefficients(k));
        assert_eq!(localised.bands(), BANDS);
        let fitted = reference(&basis);
        let measured = localised.with_reference(Some(fitted.clone()));
        assert!(Arc::ptr_eq(
            measured.reference().expect("a reference"),
            &fitted
        ));
        assert!(measured.with_reference(None).reference().is_none());
        assert!(Arc::ptr_eq(
            Reconstruction::mean_material(basis.clone()).basis(),
            &basis
        ));
    }
}
