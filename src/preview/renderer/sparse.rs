//! The observed bins sparse mode shows: a per-pair buffer updated run by run.

use super::PreviewRenderer;
use crate::preview::PreviewError;
use crate::solver::BinChange;
use half::f16;

/// Changed sparse pairs closer than this are uploaded as one run (8 bytes per pair).
const SPARSE_MERGE_GAP: usize = 32;
/// u32 words per pair in the sparse buffer: pack2x16float(r, g), pack2x16float(b, observed).
pub(super) const SPARSE_WORDS: usize = 2;
/// The observed flag: f16 1.0 in the high half of a pair's second word.
const OBSERVED_BITS: u32 = 0x3C00 << 16;

impl PreviewRenderer {
    /// Sets (`after` is `Some(ρ)`) or forgets (`None`) observed bins for sparse mode, in
    /// order; only the changed runs of the per-pair buffer are uploaded. Values are stored
    /// as f16 (ρ above 65504 shows as 65504).
    pub fn update_sparse(&mut self, changes: &[BinChange]) -> Result<(), PreviewError> {
        let value = |c: &BinChange| c.after.map(|v| v.map(|x| x as f32));
        for change in changes {
            let pair = change.pair;
            if let Some(rgb) = value(change)
                && rgb.iter().any(|c| !(c.is_finite() && *c >= 0.0))
            {
                return Err(PreviewError::Invalid(format!(
                    "sparse bin pair {pair} has ρ = {rgb:?}; it must be finite and ≥ 0"
                )));
            }
        }
        let mut changed: Vec<usize> = Vec::with_capacity(changes.len());
        for change in changes {
            let pair = change.pair.index();
            let words = match value(change) {
                None => [0, 0],
                Some([r, g, b]) => {
                    let h = |c: f32| f16::from_f32(c.min(f16::MAX.to_f32())).to_bits() as u32;
                    [h(r) | (h(g) << 16), h(b) | OBSERVED_BITS]
                }
            };
            self.sparse_words[pair * SPARSE_WORDS..(pair + 1) * SPARSE_WORDS]
                .copy_from_slice(&words);
            changed.push(pair);
        }
        changed.sort_unstable();
        changed.dedup();
        let mut i = 0;
        while i < changed.len() {
            let start = changed[i];
            let mut end = start;
            i += 1;
            while i < changed.len() && changed[i] - end <= SPARSE_MERGE_GAP {
                end = changed[i];
                i += 1;
            }
            let words = &self.sparse_words[start * SPARSE_WORDS..(end + 1) * SPARSE_WORDS];
            self.queue.write_buffer(
                &self.sparse,
                (start * SPARSE_WORDS * 4) as u64,
                bytemuck::cast_slice(words),
            );
        }
        self.values_generation += 1;
        Ok(())
    }

    /// Forgets every observed bin.
    pub fn clear_sparse(&mut self) {
        self.sparse_words.fill(0);
        let mut encoder = self
            .device
            .create_command_encoder(&wgpu::CommandEncoderDescriptor {
                label: Some("preview clear sparse"),
            });
        encoder.clear_buffer(&self.sparse, 0, None);
        self.queue.submit([encoder.finish()]);
        self.values_generation += 1;
    }
}
