//! The sparse table: painted samples binned by (light, view) direction pair.
//!
//! Each sample is identified by (view, pixel), so repainting a pixel replaces its sample.
//! A bin keeps its samples sorted by key and recomputes its value from them on every change:
//! exact, order-independent (bit-identical to a batch build) and drift-free.

use crate::table::{DirIndex, PairIndex, pair_index};
use std::collections::{BTreeMap, HashMap};

/// Identifies one sample: a pixel of a view.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub struct SampleKey {
    pub view: u32,
    pub pixel: u32,
}

/// How several samples in one bin become its value.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash)]
pub enum Policy {
    /// The mean of the samples, per channel.
    #[default]
    Mean,
    /// The darkest sample (by Rec. 709 luminance), so its colour stays whole.
    Min,
    /// The brightest sample (by Rec. 709 luminance).
    Max,
}

impl std::str::FromStr for Policy {
    type Err = String;
    fn from_str(s: &str) -> Result<Self, String> {
        match s {
            "mean" => Ok(Self::Mean),
            "min" => Ok(Self::Min),
            "max" => Ok(Self::Max),
            other => Err(format!(
                "unknown sample policy '{other}' (expected mean, min or max)"
            )),
        }
    }
}

/// The name [`FromStr`](std::str::FromStr) reads back.
impl std::fmt::Display for Policy {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(match self {
            Self::Mean => "mean",
            Self::Min => "min",
            Self::Max => "max",
        })
    }
}

/// What a sample's channel says about the BRDF: its value, or only a bound. Paint clipped at
/// the top of an 8-bit range says "at least this bright", paint at its bottom "at most this
/// dark" (LDR paint is censored data).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash)]
pub enum Bound {
    #[default]
    Exact,
    AtLeast,
    AtMost,
}

/// A bound per channel (R, G, B).
pub type Bounds = [Bound; 3];

/// Every channel exact: what HDR paint and the app's canvas give.
pub const EXACT: Bounds = [Bound::Exact; 3];

/// A bin whose value, bounds or consistency changed: `before`/`after` are `None` when the
/// bin was/is empty; `bounds` says what `after` means per channel ([`EXACT`] when it is
/// `None`). The one type of a bin's change along the whole flow: the sparse table emits it,
/// the solver applies it, the worker coalesces a batch's changes and forwards them to the
/// UI, and the preview converts `after` to f32 only when it uploads it.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct BinChange {
    pub pair: PairIndex,
    pub before: Option<[f64; 3]>,
    pub after: Option<[f64; 3]>,
    pub bounds: Bounds,
    /// How finely `after`'s exact channels are known, in ln ρ: half the rounding step of the
    /// 8-bit paint every sample of the bin came from, the least over them; 0 where any sample
    /// is exact (HDR paint, the app's canvas) or the bin is empty. See [`Reading::rounding`].
    pub rounding: f64,
    /// Whether the bin's samples now disagree beyond the inconsistency factor.
    pub inconsistent: bool,
}

/// What one painted pixel says of ρ: its value, what each channel's value means, and how
/// finely 8-bit paint knows it.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Reading {
    /// ρ in 1/sr, linear RGB.
    pub rho: [f64; 3],
    pub bounds: Bounds,
    /// Half the rounding step of the paint at this value, in ln ρ (0: exact). An 8-bit pixel
    /// is any value within half a step of its own; a change of ρ smaller than that is one
    /// the paint cannot show.
    pub rounding: f64,
}

impl Reading {
    /// An exact value (HDR paint) or bounds, with no rounding.
    pub fn exact(rho: [f64; 3], bounds: Bounds) -> Self {
        Self {
            rho,
            bounds,
            rounding: 0.0,
        }
    }
}

impl BinChange {
    /// A change from nothing to `after`, marked consistent: a bin as a new solver (which
    /// reads no consistency) or a test first sees it.
    pub fn observed(pair: PairIndex, after: [f64; 3], bounds: Bounds) -> Self {
        Self {
            pair,
            before: None,
            after: Some(after),
            bounds,
            rounding: 0.0,
            inconsistent: false,
        }
    }

    /// Each pair of `changes` once, in pair order: the first change's `before` with the
    /// last one's state.
    pub fn coalesce(changes: &[BinChange]) -> Vec<BinChange> {
        let mut merged = changes.to_vec();
        // Stable: a pair's changes keep their order.
        merged.sort_by_key(|c| c.pair);
        merged.dedup_by(|later, first| {
            if later.pair != first.pair {
                return false;
            }
            first.after = later.after;
            first.bounds = later.bounds;
            first.rounding = later.rounding;
            first.inconsistent = later.inconsistent;
            true
        });
        merged
    }
}

/// Why a sample was not taken.
#[derive(Clone, Copy, Debug, PartialEq, thiserror::Error)]
pub enum SampleRejected {
    #[error("sample value is NaN or infinite")]
    NotFinite,
    #[error("sample value is negative")]
    Negative,
}

/// One sample in a bin.
#[derive(Clone, Copy, Debug)]
struct Held {
    key: SampleKey,
    rho: [f64; 3],
    bounds: Bounds,
    rounding: f64,
}

#[derive(Clone, Debug, Default)]
struct Bin {
    /// Sorted by key.
    samples: Vec<Held>,
    value: [f64; 3],
    bounds: Bounds,
    /// The least rounding of its samples ([`BinChange::rounding`]).
    rounding: f64,
    /// Kept with the value, so that counting and reporting inconsistent bins never rescans.
    inconsistent: bool,
}

fn luminance(rgb: &[f64; 3]) -> f64 {
    0.2126 * rgb[0] + 0.7152 * rgb[1] + 0.0722 * rgb[2]
}

impl Bin {
    /// Per channel: a bound as soon as one sample is clipped at the top (the bin's value can
    /// then only be too low), an upper bound when every sample is clipped at the bottom.
    fn aggregate_bounds(&self) -> Bounds {
        std::array::from_fn(|c| {
            if self.samples.iter().any(|s| s.bounds[c] == Bound::AtLeast) {
                Bound::AtLeast
            } else if self.samples.iter().all(|s| s.bounds[c] == Bound::AtMost) {
                Bound::AtMost
            } else {
                Bound::Exact
            }
        })
    }

    /// The rounding of the bin's value: its samples' least, so 0 as soon as one is exact.
    fn aggregate_rounding(&self) -> f64 {
        self.samples
            .iter()
            .map(|s| s.rounding)
            .fold(f64::INFINITY, f64::min)
    }

    fn aggregate(&self, policy: Policy) -> [f64; 3] {
        match policy {
            Policy::Mean => {
                // Pre-divided terms cannot overflow where the samples near f64::MAX; the mean
                // never exceeds the largest sample, which also bounds the sum's rounding.
                let n = self.samples.len() as f64;
                let mut sum = [0.0f64; 3];
                let mut largest = [0.0f64; 3];
                for Held { rho: v, .. } in &self.samples {
                    for c in 0..3 {
                        sum[c] += v[c] / n;
                        largest[c] = largest[c].max(v[c]);
                    }
                }
                std::array::from_fn(|c| sum[c].min(largest[c]))
            }
            Policy::Min => self.pick(|a, b| a < b),
            Policy::Max => self.pick(|a, b| a > b),
        }
    }

    /// The sample whose luminance `better` prefers; ties go to the smallest key.
    fn pick(&self, better: impl Fn(f64, f64) -> bool) -> [f64; 3] {
        let mut best = self.samples[0].rho;
        for Held { rho: v, .. } in &self.samples[1..] {
            if better(luminance(v), luminance(&best)) {
                best = *v;
            }
        }
        best
    }

    /// Whether the samples disagree beyond `ratio` (two at least).
    fn disagrees(&self, ratio: f64) -> bool {
        self.samples.len() > 1 && self.spread() > ratio
    }

    /// Ratio of brightest to darkest sample luminance (with a small floor).
    fn spread(&self) -> f64 {
        const FLOOR: f64 = 1e-3;
        let (mut lo, mut hi) = (f64::INFINITY, 0.0f64);
        for Held { rho: v, .. } in &self.samples {
            let y = luminance(v);
            lo = lo.min(y);
            hi = hi.max(y);
        }
        (hi + FLOOR) / (lo + FLOOR)
    }
}

/// Binned samples of every view of a session.
#[derive(Clone, Debug)]
pub struct SparseTable {
    policy: Policy,
    /// Samples of one bin whose luminances differ by more than this factor are inconsistent.
    inconsistency_ratio: f64,
    sample_bins: HashMap<SampleKey, PairIndex>,
    bins: BTreeMap<PairIndex, Bin>,
    /// Bins whose `inconsistent` is set.
    inconsistent: usize,
}

impl Default for SparseTable {
    fn default() -> Self {
        Self::new(Policy::Mean)
    }
}

impl SparseTable {
    /// Default factor between a bin's brightest and darkest sample beyond which it is inconsistent.
    pub const DEFAULT_INCONSISTENCY_RATIO: f64 = 1.5;

    pub fn new(policy: Policy) -> Self {
        Self {
            policy,
            inconsistency_ratio: Self::DEFAULT_INCONSISTENCY_RATIO,
            sample_bins: HashMap::new(),
            bins: BTreeMap::new(),
            inconsistent: 0,
        }
    }

    pub fn policy(&self) -> Policy {
        self.policy
    }

    /// Sets the inconsistency factor (> 1); bins whose consistency flips are reported.
    pub fn set_inconsistency_ratio(&mut self, ratio: f64, changes: &mut Vec<BinChange>) {
        self.inconsistency_ratio = ratio.max(1.0);
        for (&pair, bin) in self.bins.iter_mut() {
            let inconsistent = bin.disagrees(self.inconsistency_ratio);
            if inconsistent != bin.inconsistent {
                bin.inconsistent = inconsistent;
                if inconsistent {
                    self.inconsistent += 1;
                } else {
                    self.inconsistent -= 1;
                }
                changes.push(BinChange {
                    pair,
                    before: Some(bin.value),
                    after: Some(bin.value),
                    bounds: bin.bounds,
                    rounding: bin.rounding,
                    inconsistent,
                });
            }
        }
    }

    /// Number of samples held.
    pub fn sample_count(&self) -> usize {
        self.sample_bins.len()
    }

    /// Number of bins with at least one sample.
    pub fn observed_count(&self) -> usize {
        self.bins.len()
    }

    /// The value of the bin of pair index `pair`, if observed.
    pub fn bin_value(&self, pair: PairIndex) -> Option<[f64; 3]> {
        self.bins.get(&pair).map(|b| b.value)
    }

    /// Observed bins and their values, in pair order.
    pub fn observed(&self) -> impl Iterator<Item = (PairIndex, [f64; 3])> + '_ {
        self.bins.iter().map(|(&p, b)| (p, b.value))
    }

    /// Observed bins with their values and what each channel's value means, in pair order.
    pub fn observed_bounded(&self) -> impl Iterator<Item = (PairIndex, [f64; 3], Bounds)> + '_ {
        self.bins.iter().map(|(&p, b)| (p, b.value, b.bounds))
    }

    /// Every observed bin as a change from nothing, bounds and rounding included: what a new
    /// solver applies to catch up with the table.
    pub fn observed_changes(&self) -> impl Iterator<Item = BinChange> + '_ {
        self.bins.iter().map(|(&pair, b)| BinChange {
            rounding: b.rounding,
            ..BinChange::observed(pair, b.value, b.bounds)
        })
    }

    /// Number of samples in the bin of `pair`.
    pub fn samples_in(&self, pair: PairIndex) -> usize {
        self.bins.get(&pair).map_or(0, |b| b.samples.len())
    }

    /// Bins whose samples disagree beyond the inconsistency factor, in pair order.
    pub fn inconsistent_bins(&self) -> impl Iterator<Item = PairIndex> + '_ {
        self.bins
            .iter()
            .filter(|(_, b)| b.inconsistent)
            .map(|(&p, _)| p)
    }

    /// Whether the bin's samples disagree beyond the inconsistency factor.
    pub fn is_inconsistent(&self, pair: PairIndex) -> bool {
        self.bins.get(&pair).is_some_and(|b| b.inconsistent)
    }

    pub fn inconsistent_count(&self) -> usize {
        self.inconsistent
    }

    /// Adds or replaces the sample `key` with value `rho` in bin (d_l, d_v).
    /// Bins whose value changed are appended to `changes`.
    pub fn set_sample(
        &mut self,
        key: SampleKey,
        d_l: DirIndex,
        d_v: DirIndex,
        rho: [f64; 3],
        changes: &mut Vec<BinChange>,
    ) -> Result<(), SampleRejected> {
        self.set_bounded_sample(key, d_l, d_v, rho, EXACT, changes)
    }

    /// [`Self::set_sample`] for a sample whose channels may be bounds rather than values.
    pub fn set_bounded_sample(
        &mut self,
        key: SampleKey,
        d_l: DirIndex,
        d_v: DirIndex,
        rho: [f64; 3],
        bounds: Bounds,
        changes: &mut Vec<BinChange>,
    ) -> Result<(), SampleRejected> {
        self.set_reading(key, d_l, d_v, Reading::exact(rho, bounds), changes)
    }

    /// [`Self::set_sample`] for a pixel's whole reading: its value, bounds and rounding.
    pub fn set_reading(
        &mut self,
        key: SampleKey,
        d_l: DirIndex,
        d_v: DirIndex,
        reading: Reading,
        changes: &mut Vec<BinChange>,
    ) -> Result<(), SampleRejected> {
        let Reading {
            rho,
            bounds,
            rounding,
        } = reading;
        if rho.iter().any(|c| !c.is_finite()) {
            return Err(SampleRejected::NotFinite);
        }
        if rho.iter().any(|&c| c < 0.0) {
            return Err(SampleRejected::Negative);
        }
        // −0 is a valid zero; store +0 so no table ever carries a negative sign.
        let rho = rho.map(|c| if c == 0.0 { 0.0 } else { c });
        let pair = pair_index(d_l, d_v);
        match self.sample_bins.insert(key, pair) {
            Some(old_pair) if old_pair != pair => {
                self.edit_bin(old_pair, changes, |s| s.retain(|h| h.key != key));
            }
            _ => {}
        }
        let held = Held {
            key,
            rho,
            bounds,
            // Never negative nor NaN: a rounding only ever widens what counts as unseen.
            rounding: if rounding.is_finite() && rounding > 0.0 {
                rounding
            } else {
                0.0
            },
        };
        self.edit_bin(pair, changes, |samples| {
            match samples.binary_search_by_key(&key, |h| h.key) {
                Ok(i) => samples[i] = held,
                Err(i) => samples.insert(i, held),
            }
        });
        Ok(())
    }

    /// Removes the sample `key`, if present.
    pub fn remove_sample(&mut self, key: SampleKey, changes: &mut Vec<BinChange>) {
        if let Some(pair) = self.sample_bins.remove(&key) {
            self.edit_bin(pair, changes, |s| s.retain(|h| h.key != key));
        }
    }

    /// Removes every sample of `view` (a view muted or closed).
    pub fn remove_view(&mut self, view: u32, changes: &mut Vec<BinChange>) {
        let mut keys: Vec<SampleKey> = self
            .sample_bins
            .keys()
            .filter(|k| k.view == view)
            .copied()
            .collect();
        keys.sort_unstable();
        for key in keys {
            self.remove_sample(key, changes);
        }
    }

    /// Changes the policy; every multi-sample bin whose value changes is reported.
    pub fn set_policy(&mut self, policy: Policy, changes: &mut Vec<BinChange>) {
        if policy == self.policy {
            return;
        }
        self.policy = policy;
        for (&pair, bin) in self.bins.iter_mut() {
            let value = bin.aggregate(policy);
            if value != bin.value {
                changes.push(BinChange {
                    pair,
                    before: Some(bin.value),
                    after: Some(value),
                    bounds: bin.bounds,
                    rounding: bin.rounding,
                    inconsistent: bin.inconsistent,
                });
                bin.value = value;
            }
        }
    }

    fn edit_bin(
        &mut self,
        pair: PairIndex,
        changes: &mut Vec<BinChange>,
        edit: impl FnOnce(&mut Vec<Held>),
    ) {
        let bin = self.bins.entry(pair).or_default();
        let before = (!bin.samples.is_empty()).then_some((bin.value, bin.bounds, bin.rounding));
        let was_inconsistent = bin.inconsistent;
        edit(&mut bin.samples);
        let (after, inconsistent) = if bin.samples.is_empty() {
            self.bins.remove(&pair);
            (None, false)
        } else {
            bin.value = bin.aggregate(self.policy);
            bin.bounds = bin.aggregate_bounds();
            bin.rounding = bin.aggregate_rounding();
            bin.inconsistent = bin.disagrees(self.inconsistency_ratio);
            (
                Some((bin.value, bin.bounds, bin.rounding)),
                bin.inconsistent,
            )
        };
        match (was_inconsistent, inconsistent) {
            (false, true) => self.inconsistent += 1,
            (true, false) => self.inconsistent -= 1,
            _ => {}
        }
        // A flip of consistency alone is reported too: the UI marks such bins.
        if before != after || was_inconsistent != inconsistent {
            changes.push(BinChange {
                pair,
                before: before.map(|(v, _, _)| v),
                after: after.map(|(v, _, _)| v),
                bounds: after.map_or(EXACT, |(_, b, _)| b),
                rounding: after.map_or(0.0, |(_, _, r)| r),
                inconsistent,
            });
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn key(pixel: u32) -> SampleKey {
        SampleKey { view: 0, pixel }
    }

    #[test]
    fn repainting_replaces_and_policies_aggregate() {
        let mut t = SparseTable::new(Policy::Mean);
        let mut ch = Vec::new();
        t.set_sample(key(1), 3, 9, [1.0, 1.0, 1.0], &mut ch)
            .unwrap();
        t.set_sample(key(2), 9, 3, [3.0, 3.0, 3.0], &mut ch)
            .unwrap();
        let pair = pair_index(3, 9);
        assert_eq!(t.bin_value(pair), Some([2.0; 3]));
        t.set_sample(key(2), 9, 3, [5.0, 5.0, 5.0], &mut ch)
            .unwrap();
        assert_eq!(t.bin_value(pair), Some([3.0; 3]));
        assert_eq!(t.sample_count(), 2);
        t.set_policy(Policy::Min, &mut ch);
        assert_eq!(t.bin_value(pair), Some([1.0; 3]));
        t.set_policy(Policy::Max, &mut ch);
        assert_eq!(t.bin_value(pair), Some([5.0; 3]));
        assert_eq!(t.inconsistent_bins().collect::<Vec<_>>(), vec![pair]);
        t.remove_sample(key(2), &mut ch);
        t.remove_sample(key(1), &mut ch);
        assert_eq!(t.observed_count(), 0);
        let last = ch.last().unwrap();
        assert_eq!((last.before, last.after), (Some([1.0; 3]), None));
    }

    /// Min and Max keep a whole sample's colour; between samples of equal luminance the
    /// smallest key wins, whatever order they were painted in.
    #[test]
    fn min_and_max_break_ties_by_the_smallest_key() {
        // 0.2126 · 0.7152 either way round: the same luminance to the bit.
        let red = [0.7152, 0.0, 0.0];
        let green = [0.0, 0.2126, 0.0];
        for policy in [Policy::Min, Policy::Max] {
            let mut t = SparseTable::new(policy);
            assert_eq!(t.policy(), policy);
            let mut ch = Vec::new();
            t.set_sample(key(2), 4, 7, red, &mut ch).unwrap();
            t.set_sample(key(1), 4, 7, green, &mut ch).unwrap();
            assert_eq!(t.bin_value(pair_index(4, 7)), Some(green), "{policy:?}");
        }
    }

    /// A pixel repainted within its bin is one change from the old value to the new, never a
    /// removal and a re-insertion (the worker would see the bin vanish in between).
    #[test]
    fn repainting_within_a_bin_is_one_change() {
        let mut t = SparseTable::default();
        let mut ch = Vec::new();
        t.set_sample(key(5), 2, 6, [1.0; 3], &mut ch).unwrap();
        ch.clear();
        t.set_sample(key(5), 2, 6, [3.0; 3], &mut ch).unwrap();
        assert_eq!(ch.len(), 1, "{ch:?}");
        assert_eq!(
            (ch[0].pair, ch[0].before, ch[0].after),
            (pair_index(2, 6), Some([1.0; 3]), Some([3.0; 3]))
        );
    }

    #[test]
    fn policies_parse_by_name() {
        for (name, policy) in [
            ("mean", Policy::Mean),
            ("min", Policy::Min),
            ("max", Policy::Max),
        ] {
            assert_eq!(name.parse::<Policy>(), Ok(policy));
        }
        let error = "median".parse::<Policy>().unwrap_err();
        assert!(error.contains("median"), "{error}");
    }

    #[test]
    fn bad_values_are_rejected_and_change_nothing() {
        let mut t = SparseTable::default();
        let mut ch = Vec::new();
        assert_eq!(
            t.set_sample(key(0), 0, 0, [f64::NAN, 0.0, 0.0], &mut ch),
            Err(SampleRejected::NotFinite)
        );
        assert_eq!(
            t.set_sample(key(0), 0, 0, [0.0, f64::INFINITY, 0.0], &mut ch),
            Err(SampleRejected::NotFinite)
        );
        assert_eq!(
            t.set_sample(key(0), 0, 0, [0.0, 0.0, -1.0], &mut ch),
            Err(SampleRejected::Negative)
        );
        assert!(ch.is_empty());
        assert_eq!(t.sample_count(), 0);
    }

    #[test]
    fn consistency_is_reported_even_when_the_value_stays() {
        let mut t = SparseTable::new(Policy::Min);
        let mut ch = Vec::new();
        t.set_sample(key(1), 3, 9, [1.0; 3], &mut ch).unwrap();
        // Under Min a brighter sample leaves the value, but the bin now disagrees.
        t.set_sample(key(2), 3, 9, [5.0; 3], &mut ch).unwrap();
        assert_eq!(t.inconsistent_count(), 1);
        let last = ch.last().unwrap();
        assert_eq!((last.before, last.after), (Some([1.0; 3]), Some([1.0; 3])));
        assert!(last.inconsistent);
        let merged = BinChange::coalesce(&ch);
        assert_eq!(merged.len(), 1);
        assert_eq!((merged[0].before, merged[0].after), (None, Some([1.0; 3])));
        assert!(merged[0].inconsistent);
        t.remove_sample(key(2), &mut ch);
        assert_eq!(t.inconsistent_count(), 0);
        assert!(!ch.last().unwrap().inconsistent);
    }

    #[test]
    fn a_sample_that_moves_bins_leaves_the_old_one() {
        let mut t = SparseTable::default();
        let mut ch = Vec::new();
        t.set_sample(key(0), 1, 2, [1.0; 3], &mut ch).unwrap();
        t.set_sample(key(0), 5, 6, [1.0; 3], &mut ch).unwrap();
        assert_eq!(t.observed_count(), 1);
        assert_eq!(t.bin_value(pair_index(1, 2)), None);
    }

    /// A bin's rounding is its samples' least: 8-bit paint's half step until an exact sample
    /// joins. It is reported with the bin's change, and kept for a new solver.
    #[test]
    fn a_bins_rounding_is_its_finest_samples() {
        let mut t = SparseTable::default();
        let mut ch = Vec::new();
        let reading = |rounding| Reading {
            rho: [0.2; 3],
            bounds: EXACT,
            rounding,
        };
        t.set_reading(key(1), 4, 40, reading(0.02), &mut ch)
            .unwrap();
        assert_eq!(ch.last().unwrap().rounding, 0.02);
        t.set_reading(key(2), 40, 4, reading(0.005), &mut ch)
            .unwrap();
        assert_eq!(ch.last().unwrap().rounding, 0.005);
        let kept: Vec<BinChange> = t.observed_changes().collect();
        assert_eq!(kept.len(), 1);
        assert_eq!(kept[0].rounding, 0.005);
        assert_eq!(kept[0].after, Some([0.2; 3]));
        // The value alone is unchanged, the rounding is not: still a change.
        t.set_sample(key(3), 4, 40, [0.2; 3], &mut ch).unwrap();
        assert_eq!(ch.last().unwrap().rounding, 0.0);
        t.remove_sample(key(3), &mut ch);
        assert_eq!(ch.last().unwrap().rounding, 0.005);
        // Nonsense roundings widen nothing.
        t.set_reading(key(1), 4, 40, reading(f64::NAN), &mut ch)
            .unwrap();
        t.set_reading(key(2), 40, 4, reading(-1.0), &mut ch)
            .unwrap();
        assert_eq!(ch.last().unwrap().rounding, 0.0);
    }

    /// A bin's bounds: "at least" as soon as one sample is clipped at the top, "at most" only
    /// while every sample is clipped at the bottom.
    #[test]
    fn a_bins_bounds_follow_its_clipped_samples() {
        use Bound::{AtLeast, AtMost, Exact};
        let mut t = SparseTable::default();
        let mut ch = Vec::new();
        let pair = pair_index(4, 40);
        let bounds_now = |t: &SparseTable| t.observed_bounded().next().unwrap().2;
        t.set_bounded_sample(
            key(1),
            4,
            40,
            [1.0, 0.5, 0.0],
            [AtLeast, Exact, AtMost],
            &mut ch,
        )
        .unwrap();
        assert_eq!(bounds_now(&t), [AtLeast, Exact, AtMost]);
        assert_eq!(ch.last().unwrap().bounds, [AtLeast, Exact, AtMost]);
        t.set_bounded_sample(
            key(2),
            40,
            4,
            [0.6, 0.5, 0.0],
            [Exact, AtLeast, AtMost],
            &mut ch,
        )
        .unwrap();
        assert_eq!(bounds_now(&t), [AtLeast, AtLeast, AtMost]);
        t.set_sample(key(3), 4, 40, [0.8, 0.5, 0.01], &mut ch)
            .unwrap();
        assert_eq!(bounds_now(&t), [AtLeast, AtLeast, Exact]);
        assert_eq!(t.samples_in(pair), 3);
        t.remove_sample(key(1), &mut ch);
        t.remove_sample(key(2), &mut ch);
        assert_eq!(bounds_now(&t), EXACT);
        t.remove_sample(key(3), &mut ch);
        assert_eq!(ch.last().unwrap().bounds, EXACT, "an emptied bin");
        assert_eq!(t.samples_in(pair), 0);
    }

    /// Min and Max pick by luminance (Rec. 709 weights), ties to the first key; a zero is
    /// stored as +0.
    #[test]
    fn min_and_max_pick_by_luminance() {
        let mut ch = Vec::new();
        let mut t = SparseTable::new(Policy::Max);
        // Red 1.0 is darker (0.2126) than green 0.5 (0.3576).
        t.set_sample(key(1), 2, 3, [1.0, 0.0, 0.0], &mut ch)
            .unwrap();
        t.set_sample(key(2), 2, 3, [0.0, 0.5, 0.0], &mut ch)
            .unwrap();
        assert_eq!(t.bin_value(pair_index(2, 3)), Some([0.0, 0.5, 0.0]));
        t.set_policy(Policy::Min, &mut ch);
        assert_eq!(t.bin_value(pair_index(2, 3)), Some([1.0, 0.0, 0.0]));
        // Equal luminance: the smaller key wins, whichever came first.
        let blue = 0.7152 / 0.0722;
        t.set_sample(key(9), 7, 7, [0.0, 0.0, blue], &mut ch)
            .unwrap();
        t.set_sample(key(8), 7, 7, [0.0, 1.0, 0.0], &mut ch)
            .unwrap();
        assert_eq!(t.bin_value(pair_index(7, 7)), Some([0.0, 1.0, 0.0]));
        t.set_sample(key(5), 8, 8, [-0.0, 0.0, 0.0], &mut ch)
            .unwrap();
        let zero = t.bin_value(pair_index(8, 8)).unwrap();
        assert!(zero.iter().all(|c| c.is_sign_positive()), "{zero:?}");
    }

    /// The inconsistency factor: samples apart by more are flagged, a change of the factor
    /// reports each bin that flips (value unchanged), and dark bins compare above a floor.
    #[test]
    fn the_inconsistency_factor_flags_and_reports_flips() {
        let mut t = SparseTable::new(Policy::Mean);
        let mut ch = Vec::new();
        t.set_sample(key(1), 1, 5, [1.0; 3], &mut ch).unwrap();
        t.set_sample(key(2), 1, 5, [1.4; 3], &mut ch).unwrap();
        let pair = pair_index(1, 5);
        assert!(!t.is_inconsistent(pair), "1.4 apart under the default 1.5");
        ch.clear();
        t.set_inconsistency_ratio(1.2, &mut ch);
        assert!(t.is_inconsistent(pair));
        assert_eq!(t.inconsistent_count(), 1);
        assert_eq!(ch.len(), 1);
        assert_eq!(
            (ch[0].before, ch[0].after),
            (Some([1.2; 3]), Some([1.2; 3]))
        );
        assert!(ch[0].inconsistent);
        ch.clear();
        t.set_inconsistency_ratio(1.3, &mut ch);
        assert!(ch.is_empty(), "no bin flips");
        t.set_inconsistency_ratio(2.0, &mut ch);
        assert_eq!((t.inconsistent_count(), ch.len()), (0, 1));
        assert!(!ch[0].inconsistent);
        // Luminances 0 and 5e-4 are 1.5 apart over the 1e-3 floor; 0 and 1e-3, 2.
        t.set_inconsistency_ratio(1.5, &mut ch);
        t.set_sample(key(3), 2, 2, [0.0; 3], &mut ch).unwrap();
        t.set_sample(key(4), 2, 2, [5e-4; 3], &mut ch).unwrap();
        assert!(!t.is_inconsistent(pair_index(2, 2)));
        t.set_sample(key(4), 2, 2, [1e-3; 3], &mut ch).unwrap();
        assert!(t.is_inconsistent(pair_index(2, 2)));
        assert_eq!(
            t.inconsistent_bins().collect::<Vec<_>>(),
            [pair_index(2, 2)]
        );
    }

    /// Removing a view takes its samples out of every bin and leaves the other views'.
    #[test]
    fn removing_a_view_leaves_the_others() {
        let mut t = SparseTable::new(Policy::Mean);
        let mut ch = Vec::new();
        let at = |view, pixel| SampleKey { view, pixel };
        t.set_sample(at(0, 1), 3, 4, [1.0; 3], &mut ch).unwrap();
        t.set_sample(at(1, 1), 3, 4, [3.0; 3], &mut ch).unwrap();
        t.set_sample(at(1, 2), 6, 6, [2.0; 3], &mut ch).unwrap();
        t.set_sample(at(2, 1), 6, 9, [4.0; 3], &mut ch).unwrap();
        ch.clear();
        t.remove_view(1, &mut ch);
        assert_eq!(t.sample_count(), 2);
        assert_eq!(
            t.observed().collect::<Vec<_>>(),
            [(pair_index(3, 4), [1.0; 3]), (pair_index(6, 9), [4.0; 3])]
        );
        assert_eq!(ch.len(), 2);
        assert_eq!(
            (ch[0].before, ch[0].after),
            (Some([2.0; 3]), Some([1.0; 3]))
        );
        assert_eq!((ch[1].before, ch[1].after), (Some([2.0; 3]), None));
    }
}
