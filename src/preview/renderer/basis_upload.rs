//! Uploading a basis (once per basis), the reconstruction's coefficients (per snapshot) and a
//! fitted reference's offsets (per fit).

use super::{GpuBasis, PreviewRenderer, allocate, buffer_entry, check_fits};
use crate::basis::{Basis, MAP_EPSILON, RANGE_MARGIN, cos_weight_polar};
use crate::preview::PreviewError;
use crate::solver::{BANDS, FittedReference, pair_bands};
use crate::table::{PAIRS, THETA_BINS};
use half::f16;
use rayon::prelude::*;
use std::sync::Arc;
use wgpu::util::DeviceExt;

/// Invocations per workgroup of the reconstruction pass (shaders/reconstruct.wgsl).
const WORKGROUP_SIZE: u32 = 256;
/// Pairs packed and uploaded at a time when a basis is set, to bound the staging memory.
const UPLOAD_CHUNK_PAIRS: usize = 1 << 16;

/// The power of two the basis components are multiplied by before they are rounded to f16:
/// it puts the largest magnitude just under 2¹⁴, far from f16's overflow (65504) and its
/// subnormals (below 6.1 · 10⁻⁵), so that rounding costs the same relative 2⁻¹¹ everywhere.
fn component_scale(rows: &[f32]) -> Result<f32, PreviewError> {
    let largest = rows.par_iter().map(|v| v.abs()).reduce(
        || 0.0,
        |a: f32, b: f32| {
            if a.is_nan() || b.is_nan() {
                f32::NAN
            } else {
                a.max(b)
            }
        },
    );
    if !largest.is_finite() {
        return Err(PreviewError::Invalid(
            "the basis has components that are not finite".into(),
        ));
    }
    if largest == 0.0 {
        return Ok(1.0);
    }
    let exponent = 14 - largest.log2().ceil() as i32;
    Ok(2f32.powi(exponent))
}

impl PreviewRenderer {
    /// Uploads a basis (once per basis): its components as f16 pairs, and per pair the
    /// reference, mean and mapped range. The coefficients start at zero (the mean material),
    /// measured from the basis's mean (no fitted reference).
    pub fn set_basis(&mut self, basis: &Basis) -> Result<(), PreviewError> {
        let k = basis.components();
        if k == 0 {
            return Err(PreviewError::Invalid("the basis has no components".into()));
        }
        let row_words = k.div_ceil(2);
        let rows_bytes = (PAIRS * row_words * 4) as u64;
        check_fits(
            &self.limits,
            &format!("a basis of K = {k} components (f16, {row_words} words per pair)"),
            rows_bytes,
        )?;
        // Per pair one vec4 of the map's constants, then (after all of them) one vec4 of a
        // fitted reference's offsets: the pass already binds the most storage buffers a
        // stage may have by default (8), so the offsets share the ranges' buffer.
        let ranges_bytes = (2 * PAIRS * 16) as u64;
        check_fits(
            &self.limits,
            "the basis's per-pair ranges and offsets",
            ranges_bytes,
        )?;
        let rows = basis.rows();
        let scale = component_scale(rows)?;

        let device = &self.device;
        let usage = wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_DST;
        let buffer = |label: &str, size: u64, usage: wgpu::BufferUsages| {
            device.create_buffer(&wgpu::BufferDescriptor {
                label: Some(label),
                size,
                usage,
                mapped_at_creation: false,
            })
        };
        // One vec4 per component, padded to an even count for the shader's pairs, for each
        // of the localised prior's coefficient sets.
        let coefficient_bytes = (BANDS * 2 * row_words * 16) as u64;
        let (rows_buffer, ranges, coefficients, output) = allocate(device, || {
            (
                buffer("preview basis components", rows_bytes, usage),
                buffer("preview basis ranges", ranges_bytes, usage),
                buffer("preview coefficients", coefficient_bytes, usage),
                buffer(
                    "preview reconstruction",
                    (PAIRS * 3 * 4) as u64,
                    wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_SRC,
                ),
            )
        })?;
        let (marked, listed, listed_counts) = allocate(device, || {
            (
                buffer("preview pair marks", (PAIRS * 4) as u64, usage),
                buffer(
                    "preview listed pairs",
                    (PAIRS * 4) as u64,
                    wgpu::BufferUsages::STORAGE,
                ),
                buffer(
                    "preview listed pair counts",
                    16,
                    usage | wgpu::BufferUsages::INDIRECT | wgpu::BufferUsages::COPY_SRC,
                ),
            )
        })?;

        let (references, means, lowers, uppers) = (
            basis.references(),
            basis.means(),
            basis.lowers(),
            basis.uppers(),
        );
        let mut words = Vec::new();
        let mut range_values = Vec::new();
        for start in (0..PAIRS).step_by(UPLOAD_CHUNK_PAIRS) {
            let end = (start + UPLOAD_CHUNK_PAIRS).min(PAIRS);
            words.clear();
            words.resize((end - start) * row_words, 0u32);
            words
                .par_chunks_mut(row_words)
                .enumerate()
                .for_each(|(i, out)| {
                    let row = &rows[(start + i) * k..(start + i + 1) * k];
                    for (j, word) in out.iter_mut().enumerate() {
                        let half = |c: usize| {
                            row.get(c)
                                .map_or(0, |&u| f16::from_f32(u * scale).to_bits() as u32)
                        };
                        *word = half(2 * j) | (half(2 * j + 1) << 16);
                    }
                });
            self.queue.write_buffer(
                &rows_buffer,
                (start * row_words * 4) as u64,
                bytemuck::cast_slice(&words),
            );
            // The same f32 sums as the engine's evaluator.
            range_values.clear();
            range_values.extend((start..end).map(|p| {
                [
                    references[p] + MAP_EPSILON as f32,
                    means[p],
                    lowers[p] - RANGE_MARGIN,
                    uppers[p] + RANGE_MARGIN,
                ]
            }));
            self.queue.write_buffer(
                &ranges,
                (start * 16) as u64,
                bytemuck::cast_slice(&range_values),
            );
        }
        let inverse_weights: Vec<f32> = (0..THETA_BINS * THETA_BINS)
            .map(|i| (1.0 / cos_weight_polar(i / THETA_BINS, i % THETA_BINS)) as f32)
            .collect();
        let inverse_weights = device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
            label: Some("preview inverse cosine weights"),
            contents: bytemuck::cast_slice(&inverse_weights),
            usage: wgpu::BufferUsages::STORAGE,
        });
        // The engine's band weights, as lower + frac in one float per pair, so the GPU blends
        // the coefficient sets exactly as solver::Reconstruction does.
        let band_positions: Vec<f32> = pair_bands()
            .iter()
            .map(|w| w.lower as f32 + w.frac)
            .collect();
        let band_positions = device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
            label: Some("preview pair bands"),
            contents: bytemuck::cast_slice(&band_positions),
            usage: wgpu::BufferUsages::STORAGE,
        });
        let groups = (PAIRS as u32).div_ceil(WORKGROUP_SIZE);
        let max_groups = self.limits.max_compute_workgroups_per_dimension.max(1);
        let workgroups = if groups <= max_groups {
            (groups, 1)
        } else {
            (max_groups, groups.div_ceil(max_groups))
        };
        let params = device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
            label: Some("preview reconstruction parameters"),
            contents: bytemuck::cast_slice(&[
                row_words as u32,
                PAIRS as u32,
                workgroups.0 * WORKGROUP_SIZE,
                BANDS as u32,
            ]),
            usage: wgpu::BufferUsages::UNIFORM,
        });
        let bind_group = device.create_bind_group(&wgpu::BindGroupDescriptor {
            label: Some("preview reconstruction"),
            layout: &self.pipelines.layouts.reconstruction,
            entries: &[
                buffer_entry(0, &params),
                buffer_entry(1, &coefficients),
                buffer_entry(2, &rows_buffer),
                buffer_entry(3, &ranges),
                buffer_entry(4, &inverse_weights),
                buffer_entry(5, &output),
                buffer_entry(6, &listed),
                buffer_entry(7, &listed_counts),
                buffer_entry(8, &band_positions),
            ],
        });
        let pairs_params = device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
            label: Some("preview view pairs parameters"),
            contents: bytemuck::cast_slice(&[
                PAIRS as u32,
                workgroups.0 * WORKGROUP_SIZE,
                max_groups,
                0,
            ]),
            usage: wgpu::BufferUsages::UNIFORM,
        });
        let pairs_bind_group = device.create_bind_group(&wgpu::BindGroupDescriptor {
            label: Some("preview view pairs"),
            layout: &self.pipelines.layouts.view_pairs,
            entries: &[
                buffer_entry(0, &pairs_params),
                buffer_entry(1, &marked),
                buffer_entry(2, &listed),
                buffer_entry(3, &listed_counts),
            ],
        });
        self.queue
            .write_buffer(&coefficients, 0, &vec![0u8; coefficient_bytes as usize]);
        // A new buffer reads as zeros (wgpu clears it): offsets of no fitted reference.
        self.basis = Some(GpuBasis {
            components: k,
            scale,
            ranges,
            fitted: None,
            coefficients,
            output,
            bind_group,
            workgroups,
            marked,
            listed_counts,
            pairs_bind_group,
        });
        self.reconstruction_stale = true;
        self.reconstruction_complete = false;
        // The marks and the list live in the new basis's buffers: set them up again.
        self.listed = false;
        self.geometry_key = None;
        self.values_generation += 1;
        Ok(())
    }

    /// The reconstruction's coefficients as the solver gives them: K rows of (R, G, B) (one
    /// set, used at every θ_d) or [`BANDS`] × K (the localised prior's sets). Only these
    /// numbers are uploaded; ρ is re-evaluated on the GPU at the next frame.
    pub fn set_coefficients(&mut self, x: &[[f64; 3]]) -> Result<(), PreviewError> {
        let basis = self
            .basis
            .as_ref()
            .ok_or(PreviewError::Missing("set a basis before its coefficients"))?;
        let k = basis.components;
        if x.len() != k && x.len() != BANDS * k {
            return Err(PreviewError::Invalid(format!(
                "{} coefficient rows for a basis of {} components ({k} or {} expected)",
                x.len(),
                k,
                BANDS * k
            )));
        }
        if x.iter().flatten().any(|v| !v.is_finite()) {
            return Err(PreviewError::Invalid(
                "the coefficients must be finite".into(),
            ));
        }
        // x / scale is exact: scale is a power of two. Each set is padded to an even count of
        // components; one set is repeated for every band.
        let padded = k.div_ceil(2) * 2;
        let packed: Vec<[f32; 4]> = (0..BANDS)
            .flat_map(|band| {
                let set = if x.len() == k { 0 } else { band };
                (0..padded).map(move |i| match x.get(set * k + i).filter(|_| i < k) {
                    Some(row) => {
                        let c = row.map(|v| v as f32 / basis.scale);
                        [c[0], c[1], c[2], 0.0]
                    }
                    None => [0.0; 4],
                })
            })
            .collect();
        self.queue
            .write_buffer(&basis.coefficients, 0, bytemuck::cast_slice(&packed));
        self.reconstruction_stale = true;
        self.values_generation += 1;
        Ok(())
    }

    /// The fitted reference the coefficients are measured from (`None`: the basis's mean), as
    /// [`crate::solver::Reconstruction::with_reference`] takes it. Its offsets (16 MB) are
    /// uploaded only when the reference is another one than the GPU holds: once per fit.
    pub fn set_fitted_reference(
        &mut self,
        reference: Option<&Arc<FittedReference>>,
    ) -> Result<(), PreviewError> {
        let basis = self.basis.as_mut().ok_or(PreviewError::Missing(
            "set a basis before a fitted reference",
        ))?;
        let same = match (&basis.fitted, reference) {
            (Some(a), Some(b)) => Arc::ptr_eq(a, b),
            (None, None) => true,
            _ => false,
        };
        if same {
            return Ok(());
        }
        let mut packed = Vec::with_capacity(UPLOAD_CHUNK_PAIRS);
        for start in (0..PAIRS).step_by(UPLOAD_CHUNK_PAIRS) {
            let end = (start + UPLOAD_CHUNK_PAIRS).min(PAIRS);
            packed.clear();
            match reference {
                Some(r) => packed.extend(
                    r.offsets()[start..end]
                        .iter()
                        .map(|o| [o[0], o[1], o[2], 0.0]),
                ),
                None => packed.resize(end - start, [0f32; 4]),
            }
            self.queue.write_buffer(
                &basis.ranges,
                ((PAIRS + start) * 16) as u64,
                bytemuck::cast_slice(&packed),
            );
        }
        basis.fitted = reference.cloned();
        self.reconstruction_stale = true;
        self.values_generation += 1;
        Ok(())
    }
}
