//! The frame's passes: what `prepare` redoes when the camera, lights, object, coefficients or
//! size change, the copy into the caller's pass, and the off-screen targets they draw into.

use super::{
    DEPTH_FORMAT, Evaluation, GeometryKey, PreviewRenderer, RADIANCE_FORMAT, ShadeKey, Target,
    allocate, buffer_entry, check_fits,
};
use crate::preview::PreviewError;
use crate::preview::frame::{FrameUniforms, PreviewFrame, PreviewMode};

/// u32 words per pixel of the geometry record (`RECORD` in shaders/shade.wgsl).
const RECORD_WORDS: u64 = 20;
/// Side of the set-up and gather passes' workgroups (shaders/shade.wgsl).
const PIXEL_TILE: u32 = 8;

impl PreviewRenderer {
    /// Renders `frame` at `size` (width, height in pixels) into the renderer's own linear
    /// texture. Only what changed is redone: the geometry raster, shadow map and per-pixel
    /// set-up when the camera, lights, object, environment or size did; the reconstruction of
    /// the pairs the view reads when the coefficients did; then one gather pass. When nothing
    /// changed since the last call, nothing is drawn: the texture already shows the frame.
    /// Submits its own commands.
    pub fn prepare(
        &mut self,
        device: &wgpu::Device,
        queue: &wgpu::Queue,
        frame: &PreviewFrame,
        size: [u32; 2],
    ) -> Result<(), PreviewError> {
        frame.check().map_err(PreviewError::Invalid)?;
        let [width, height] = size;
        let max = self.limits.max_texture_dimension_2d;
        if width == 0 || height == 0 || width > max || height > max {
            return Err(PreviewError::Invalid(format!(
                "a {width} × {height} preview is out of range: each side must be 1 to {max}"
            )));
        }
        match frame.mode {
            PreviewMode::Reconstruction if self.basis.is_none() => {
                return Err(PreviewError::Missing(
                    "reconstruction mode needs a basis (set_basis)",
                ));
            }
            PreviewMode::Table if self.table.is_none() => {
                return Err(PreviewError::Missing(
                    "table mode needs a table (set_table)",
                ));
            }
            _ => {}
        }
        if self.target.as_ref().is_none_or(|t| t.size != size) {
            self.target = None;
            self.target = Some(self.create_target(device, size)?);
            self.geometry_key = None;
        }
        let key = GeometryKey::new(
            frame,
            size,
            self.object_generation,
            self.environment_generation,
        );
        let geometry_changed = self.geometry_key.as_ref() != Some(&key);
        let shade_key = ShadeKey {
            frame: frame.clone(),
            size,
            values_generation: self.values_generation,
        };
        if !geometry_changed && self.shaded.as_ref() == Some(&shade_key) {
            return Ok(());
        }
        // Marks are stale from here until the set-up below is submitted.
        self.shaded = None;
        let reconstruction = frame.mode == PreviewMode::Reconstruction;
        let environment = if frame.mode == PreviewMode::SparseOnly {
            0
        } else {
            self.upload_environment(frame.environment.as_ref())
        };
        let shadows = frame.shadows && self.mesh.is_some();
        let uniforms = FrameUniforms::new(frame, width, height, shadows, environment);
        queue.write_buffer(&self.frame_uniforms, 0, bytemuck::bytes_of(&uniforms));

        let marks = self.basis.as_ref().map_or(&self.empty_marks, |b| &b.marked);
        let values = match (frame.mode, &self.basis, &self.table) {
            (PreviewMode::Reconstruction, Some(basis), _) => &basis.output,
            (PreviewMode::Table, _, Some(table)) => table,
            _ => &self.empty_values,
        };
        let target = self.target.as_ref().expect("created above");
        let texture = |binding, view| wgpu::BindGroupEntry {
            binding,
            resource: wgpu::BindingResource::TextureView(view),
        };
        let shade_bind_group = device.create_bind_group(&wgpu::BindGroupDescriptor {
            label: Some("preview shading"),
            layout: &self.pipelines.layouts.shade,
            entries: &[
                buffer_entry(0, &self.frame_uniforms),
                buffer_entry(1, values),
                buffer_entry(2, &self.sparse),
                texture(3, &target.position_view),
                texture(4, &target.normal_view),
                texture(5, &self.shadow_view),
                wgpu::BindGroupEntry {
                    binding: 6,
                    resource: wgpu::BindingResource::Sampler(&self.shadow_sampler),
                },
                buffer_entry(7, &target.records),
                buffer_entry(8, marks),
                buffer_entry(9, &self.environment_buffer),
                texture(10, &target.radiance_view),
            ],
        });
        let mut encoder = device.create_command_encoder(&wgpu::CommandEncoderDescriptor {
            label: Some("preview frame"),
        });
        let tiles = (width.div_ceil(PIXEL_TILE), height.div_ceil(PIXEL_TILE));
        if geometry_changed {
            self.encode_geometry(&mut encoder, frame, shadows);
            if let (true, Some(basis)) = (reconstruction, &self.basis) {
                // The set-up below marks afresh what this geometry reads.
                encoder.clear_buffer(&basis.marked, 0, None);
            }
            let mut pass = encoder.begin_compute_pass(&wgpu::ComputePassDescriptor {
                label: Some("preview set-up"),
                timestamp_writes: None,
            });
            pass.set_bind_group(0, &shade_bind_group, &[]);
            pass.set_pipeline(&self.pipelines.setup);
            pass.dispatch_workgroups(tiles.0, tiles.1, 1);
            drop(pass);
            if reconstruction {
                self.encode_listing(&mut encoder);
            }
            self.listed = reconstruction;
            self.geometry_key = Some(key);
            self.counts.geometry += 1;
        }
        // New coefficients, or a view onto pairs that may hold older values.
        if reconstruction
            && (self.reconstruction_stale || (geometry_changed && !self.reconstruction_complete))
        {
            self.encode_reconstruction(&mut encoder, Evaluation::Listed);
            self.counts.evaluations += 1;
        }
        {
            let mut pass = encoder.begin_compute_pass(&wgpu::ComputePassDescriptor {
                label: Some("preview gather"),
                timestamp_writes: None,
            });
            pass.set_bind_group(0, &shade_bind_group, &[]);
            if frame.draft {
                pass.set_pipeline(&self.pipelines.draft);
                let blocks = (width.div_ceil(2), height.div_ceil(2));
                pass.dispatch_workgroups(
                    blocks.0.div_ceil(PIXEL_TILE),
                    blocks.1.div_ceil(PIXEL_TILE),
                    1,
                );
            } else {
                pass.set_pipeline(&self.pipelines.gather);
                pass.dispatch_workgroups(tiles.0, tiles.1, 1);
            }
        }
        queue.submit([encoder.finish()]);
        self.shaded = Some(shade_key);
        self.counts.gathers += 1;
        Ok(())
    }

    /// Records the shadow map (when the light or object changed) and the geometry raster:
    /// per pixel, the surface point seen and its normal.
    fn encode_geometry(
        &mut self,
        encoder: &mut wgpu::CommandEncoder,
        frame: &PreviewFrame,
        shadows: bool,
    ) {
        let light = frame.light.direction().as_vec3().to_array();
        let key = (light, self.object_generation);
        if shadows && self.shadow_key != Some(key) {
            let mesh = self.mesh.as_ref().expect("shadows only for meshes");
            let mut pass = encoder.begin_render_pass(&wgpu::RenderPassDescriptor {
                label: Some("preview shadow"),
                color_attachments: &[],
                depth_stencil_attachment: Some(wgpu::RenderPassDepthStencilAttachment {
                    view: &self.shadow_view,
                    depth_ops: Some(wgpu::Operations {
                        load: wgpu::LoadOp::Clear(1.0),
                        store: wgpu::StoreOp::Store,
                    }),
                    stencil_ops: None,
                }),
                timestamp_writes: None,
                occlusion_query_set: None,
                multiview_mask: None,
            });
            pass.set_pipeline(&self.pipelines.shadow);
            pass.set_bind_group(0, &self.raster_bind_group, &[]);
            pass.set_vertex_buffer(0, mesh.vertices.slice(..));
            pass.set_index_buffer(mesh.indices.slice(..), wgpu::IndexFormat::Uint32);
            pass.draw_indexed(0..mesh.index_count, 0, 0..1);
            drop(pass);
            self.shadow_key = Some(key);
        }
        let target = self.target.as_ref().expect("created before");
        let attachment = |view| {
            Some(wgpu::RenderPassColorAttachment {
                view,
                resolve_target: None,
                depth_slice: None,
                ops: wgpu::Operations {
                    // w = 0: no surface.
                    load: wgpu::LoadOp::Clear(wgpu::Color::TRANSPARENT),
                    store: wgpu::StoreOp::Store,
                },
            })
        };
        let mut pass = encoder.begin_render_pass(&wgpu::RenderPassDescriptor {
            label: Some("preview geometry"),
            color_attachments: &[
                attachment(&target.position_view),
                attachment(&target.normal_view),
            ],
            depth_stencil_attachment: Some(wgpu::RenderPassDepthStencilAttachment {
                view: &target.depth_view,
                depth_ops: Some(wgpu::Operations {
                    load: wgpu::LoadOp::Clear(1.0),
                    store: wgpu::StoreOp::Discard,
                }),
                stencil_ops: None,
            }),
            timestamp_writes: None,
            occlusion_query_set: None,
            multiview_mask: None,
        });
        pass.set_bind_group(0, &self.raster_bind_group, &[]);
        match &self.mesh {
            None => {
                pass.set_pipeline(&self.pipelines.sphere);
                pass.draw(0..3, 0..1);
            }
            Some(mesh) => {
                pass.set_pipeline(&self.pipelines.mesh);
                pass.set_vertex_buffer(0, mesh.vertices.slice(..));
                pass.set_index_buffer(mesh.indices.slice(..), wgpu::IndexFormat::Uint32);
                pass.draw_indexed(0..mesh.index_count, 0, 0..1);
            }
        }
    }
    /// Copies the radiance texture of the last `prepare` into the caller's render pass, one
    /// texel per pixel (see the module documentation).
    /// The linear radiance the last `prepare` drew, for passes that combine two renders.
    pub(in crate::preview) fn radiance_view(&self) -> Option<&wgpu::TextureView> {
        self.target.as_ref().map(|t| &t.radiance_view)
    }

    pub fn paint(&self, render_pass: &mut wgpu::RenderPass<'_>) {
        if let Some(target) = &self.target {
            render_pass.set_pipeline(&self.pipelines.present);
            render_pass.set_bind_group(0, &target.present_bind_group, &[]);
            render_pass.draw(0..3, 0..1);
        }
    }

    /// Records the reconstruction pass over all pairs or over the listed ones.
    pub(super) fn encode_reconstruction(
        &mut self,
        encoder: &mut wgpu::CommandEncoder,
        evaluation: Evaluation,
    ) {
        let Some(basis) = &self.basis else {
            return;
        };
        let mut pass = encoder.begin_compute_pass(&wgpu::ComputePassDescriptor {
            label: Some("preview reconstruction"),
            timestamp_writes: None,
        });
        pass.set_bind_group(0, &basis.bind_group, &[]);
        if evaluation == Evaluation::All {
            pass.set_pipeline(&self.pipelines.reconstruct_all);
            pass.dispatch_workgroups(basis.workgroups.0, basis.workgroups.1, 1);
        } else {
            pass.set_pipeline(&self.pipelines.reconstruct_listed);
            pass.dispatch_workgroups_indirect(&basis.listed_counts, 4);
        }
        drop(pass);
        self.reconstruction_stale = false;
        self.reconstruction_complete = evaluation == Evaluation::All;
    }

    /// Records the passes that list the pairs the scene pass marked and size their dispatch.
    fn encode_listing(&self, encoder: &mut wgpu::CommandEncoder) {
        let Some(basis) = &self.basis else {
            return;
        };
        encoder.clear_buffer(&basis.listed_counts, 0, None);
        let mut pass = encoder.begin_compute_pass(&wgpu::ComputePassDescriptor {
            label: Some("preview view pairs"),
            timestamp_writes: None,
        });
        pass.set_bind_group(0, &basis.pairs_bind_group, &[]);
        pass.set_pipeline(&self.pipelines.compact);
        pass.dispatch_workgroups(basis.workgroups.0, basis.workgroups.1, 1);
        pass.set_pipeline(&self.pipelines.size_dispatch);
        pass.dispatch_workgroups(1, 1, 1);
    }

    fn create_target(&self, device: &wgpu::Device, size: [u32; 2]) -> Result<Target, PreviewError> {
        let record_bytes = RECORD_WORDS * 4 * size[0] as u64 * size[1] as u64;
        check_fits(
            &self.limits,
            &format!("a {} × {} preview's pixel records", size[0], size[1]),
            record_bytes,
        )?;
        let extent = wgpu::Extent3d {
            width: size[0],
            height: size[1],
            depth_or_array_layers: 1,
        };
        let texture = |label: &str, format, usage| {
            device.create_texture(&wgpu::TextureDescriptor {
                label: Some(label),
                size: extent,
                mip_level_count: 1,
                sample_count: 1,
                dimension: wgpu::TextureDimension::D2,
                format,
                usage,
                view_formats: &[],
            })
        };
        let geometry_usage =
            wgpu::TextureUsages::RENDER_ATTACHMENT | wgpu::TextureUsages::TEXTURE_BINDING;
        let (position, normal, depth, radiance, records) = allocate(device, || {
            (
                texture("preview positions", RADIANCE_FORMAT, geometry_usage),
                texture("preview normals", RADIANCE_FORMAT, geometry_usage),
                texture(
                    "preview depth",
                    DEPTH_FORMAT,
                    wgpu::TextureUsages::RENDER_ATTACHMENT,
                ),
                texture(
                    "preview radiance",
                    RADIANCE_FORMAT,
                    wgpu::TextureUsages::STORAGE_BINDING
                        | wgpu::TextureUsages::TEXTURE_BINDING
                        | wgpu::TextureUsages::COPY_SRC,
                ),
                device.create_buffer(&wgpu::BufferDescriptor {
                    label: Some("preview pixel records"),
                    size: record_bytes,
                    usage: wgpu::BufferUsages::STORAGE,
                    mapped_at_creation: false,
                }),
            )
        })?;
        let radiance_view = radiance.create_view(&Default::default());
        let present_bind_group = device.create_bind_group(&wgpu::BindGroupDescriptor {
            label: Some("preview present"),
            layout: &self.pipelines.layouts.present,
            entries: &[
                wgpu::BindGroupEntry {
                    binding: 0,
                    resource: wgpu::BindingResource::TextureView(&radiance_view),
                },
                buffer_entry(1, &self.present_options),
            ],
        });
        Ok(Target {
            size,
            position_view: position.create_view(&Default::default()),
            normal_view: normal.create_view(&Default::default()),
            depth_view: depth.create_view(&Default::default()),
            records,
            radiance,
            radiance_view,
            present_bind_group,
        })
    }
}
