//! The preview's compare mode: the reconstruction beside another material (the one the
//! painting started from, or a reference), drawn on the same object under the same camera
//! and lights, and their difference in stops.
//!
//! The compared material has a [`PreviewRenderer`] of its own, in [`PreviewMode::Table`], so
//! that each side keeps its own cached geometry and radiance: a stroke re-runs only the
//! reconstruction's gather, and the material's side is drawn again only when the camera,
//! lights or object change. The difference pass reads both renderers' linear radiance, one
//! texel per pixel (shaders/compare.wgsl). Nothing here exists until compare mode is first
//! used ([`with_compare`] creates it), so the preview costs nothing more without it.

use super::{Environment, PreviewError, PreviewFrame, PreviewMode, PreviewRenderer};
use crate::scene::Object;
use crate::table::SymTable;
use std::sync::Arc;

/// The radiance (after exposure) added to both sides before their ratio is taken: about
/// half an 8-bit display step, below which a difference cannot be seen anyway.
pub const DIFFERENCE_FLOOR: f32 = 1.0 / 512.0;

/// The colour the difference view shows for `t` = stops / saturation in [-1, 1]: black at
/// 0, blue where the reconstruction is darker, orange where it is brighter (as
/// shaders/compare.wgsl, for the legend).
pub fn difference_colour(t: f32) -> [f32; 3] {
    let t = t.clamp(-1.0, 1.0);
    let hue = if t > 0.0 {
        [1.0, 0.5, 0.1]
    } else {
        [0.25, 0.55, 1.0]
    };
    hue.map(|c| c * t.abs())
}

/// The uniform block of shaders/compare.wgsl.
#[repr(C)]
#[derive(Clone, Copy, bytemuck::Pod, bytemuck::Zeroable)]
struct DifferenceOptions {
    stops: f32,
    floor: f32,
    encode: u32,
    pad: u32,
    background: [f32; 4],
}

/// What the compared material's renderer was last given.
#[derive(Default)]
struct Uploaded {
    object: Option<Arc<Object>>,
    environment: Option<Arc<Environment>>,
    table: Option<Arc<SymTable>>,
}

/// The compared material's renderer and the difference pass; lives in egui-wgpu's callback
/// resources beside the [`PreviewRenderer`].
pub struct CompareRenderer {
    material: PreviewRenderer,
    uploaded: Uploaded,
    layout: wgpu::BindGroupLayout,
    pipeline: wgpu::RenderPipeline,
    options: wgpu::Buffer,
    encode: bool,
    /// Both sides' radiance, bound by the last difference `prepare`.
    bind_group: Option<wgpu::BindGroup>,
    last_error: Option<String>,
}

impl CompareRenderer {
    /// A renderer whose passes match `main`'s (the reconstruction's renderer).
    pub fn new(
        device: &wgpu::Device,
        queue: &wgpu::Queue,
        main: &PreviewRenderer,
    ) -> Result<Self, PreviewError> {
        let target = main.target_layout();
        let material = PreviewRenderer::with_layout(device, queue, target)?;
        let validation = device.push_error_scope(wgpu::ErrorFilter::Validation);
        let module = device.create_shader_module(wgpu::ShaderModuleDescriptor {
            label: Some("preview compare"),
            source: wgpu::ShaderSource::Wgsl(include_str!("../../shaders/compare.wgsl").into()),
        });
        let radiance = |binding| wgpu::BindGroupLayoutEntry {
            binding,
            visibility: wgpu::ShaderStages::FRAGMENT,
            ty: wgpu::BindingType::Texture {
                sample_type: wgpu::TextureSampleType::Float { filterable: false },
                view_dimension: wgpu::TextureViewDimension::D2,
                multisampled: false,
            },
            count: None,
        };
        let layout = device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
            label: Some("preview compare"),
            entries: &[
                radiance(0),
                radiance(1),
                wgpu::BindGroupLayoutEntry {
                    binding: 2,
                    visibility: wgpu::ShaderStages::FRAGMENT,
                    ty: wgpu::BindingType::Buffer {
                        ty: wgpu::BufferBindingType::Uniform,
                        has_dynamic_offset: false,
                        min_binding_size: None,
                    },
                    count: None,
                },
            ],
        });
        let pipeline_layout = device.create_pipeline_layout(&wgpu::PipelineLayoutDescriptor {
            label: Some("preview compare"),
            bind_group_layouts: &[Some(&layout)],
            immediate_size: 0,
        });
        let pipeline = device.create_render_pipeline(&wgpu::RenderPipelineDescriptor {
            label: Some("preview compare"),
            layout: Some(&pipeline_layout),
            vertex: wgpu::VertexState {
                module: &module,
                entry_point: Some("vs_compare"),
                compilation_options: Default::default(),
                buffers: &[],
            },
            primitive: wgpu::PrimitiveState::default(),
            depth_stencil: target.depth_format.map(|format| wgpu::DepthStencilState {
                format,
                depth_write_enabled: Some(false),
                depth_compare: Some(wgpu::CompareFunction::Always),
                stencil: wgpu::StencilState::default(),
                bias: wgpu::DepthBiasState::default(),
            }),
            multisample: wgpu::MultisampleState {
                count: target.samples.max(1),
                ..Default::default()
            },
            fragment: Some(wgpu::FragmentState {
                module: &module,
                entry_point: Some("fs_compare"),
                compilation_options: Default::default(),
                targets: &[Some(wgpu::ColorTargetState {
                    format: target.format,
                    blend: None,
                    write_mask: wgpu::ColorWrites::ALL,
                })],
            }),
            multiview_mask: None,
            cache: None,
        });
        let options = device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("preview compare options"),
            size: std::mem::size_of::<DifferenceOptions>() as u64,
            usage: wgpu::BufferUsages::UNIFORM | wgpu::BufferUsages::COPY_DST,
            mapped_at_creation: false,
        });
        if let Some(error) = pollster::block_on(validation.pop()) {
            return Err(PreviewError::Gpu(format!(
                "the compare pipeline could not be created for {target:?}: {error}"
            )));
        }
        Ok(Self {
            material,
            uploaded: Uploaded::default(),
            layout,
            pipeline,
            options,
            encode: !target.format.is_srgb(),
            bind_group: None,
            last_error: None,
        })
    }

    /// Gives the compared material's renderer what changed: the object, the environment and
    /// the material's table (uploaded only when it is another one).
    pub fn sync(
        &mut self,
        object: &Arc<Object>,
        environment: &Arc<Environment>,
        table: &Arc<SymTable>,
    ) -> Result<(), PreviewError> {
        fn same<T>(uploaded: &Option<Arc<T>>, now: &Arc<T>) -> bool {
            uploaded.as_ref().is_some_and(|u| Arc::ptr_eq(u, now))
        }
        if !same(&self.uploaded.object, object) {
            self.material.set_object(object)?;
            self.uploaded.object = Some(object.clone());
        }
        if !same(&self.uploaded.environment, environment) {
            self.material.set_environment(environment);
            self.uploaded.environment = Some(environment.clone());
        }
        if !same(&self.uploaded.table, table) {
            self.material.set_table(table)?;
            self.uploaded.table = Some(table.clone());
        }
        Ok(())
    }

    /// The compared material's renderer (for off-screen renders and tests).
    pub fn material_renderer(&mut self) -> &mut PreviewRenderer {
        &mut self.material
    }

    /// Renders the compared material for `frame` (whatever its mode) at `size`.
    pub fn prepare_material(
        &mut self,
        device: &wgpu::Device,
        queue: &wgpu::Queue,
        frame: &PreviewFrame,
        size: [u32; 2],
    ) -> Result<(), PreviewError> {
        let mut frame = frame.clone();
        frame.mode = PreviewMode::Table;
        self.material.prepare(device, queue, &frame, size)
    }

    /// Renders both sides for `frame` at `size` (the reconstruction with `main`) and binds
    /// them for [`Self::paint_difference`], saturating at ±`stops`.
    pub fn prepare_difference(
        &mut self,
        device: &wgpu::Device,
        queue: &wgpu::Queue,
        main: &mut PreviewRenderer,
        frame: &PreviewFrame,
        size: [u32; 2],
        stops: f32,
    ) -> Result<(), PreviewError> {
        self.bind_group = None;
        if !(stops.is_finite() && stops > 0.0) {
            return Err(PreviewError::Invalid(format!(
                "the difference scale must be a positive number of stops, not {stops}"
            )));
        }
        let mut reconstruction = frame.clone();
        reconstruction.mode = PreviewMode::Reconstruction;
        main.prepare(device, queue, &reconstruction, size)?;
        self.prepare_material(device, queue, frame, size)?;
        let (Some(a), Some(b)) = (main.radiance_view(), self.material.radiance_view()) else {
            return Err(PreviewError::Missing("the difference needs both renders"));
        };
        let [r, g, bl] = frame.background;
        let options = DifferenceOptions {
            stops,
            floor: DIFFERENCE_FLOOR,
            encode: u32::from(self.encode),
            pad: 0,
            background: [r, g, bl, 1.0],
        };
        queue.write_buffer(&self.options, 0, bytemuck::bytes_of(&options));
        self.bind_group = Some(device.create_bind_group(&wgpu::BindGroupDescriptor {
            label: Some("preview compare"),
            layout: &self.layout,
            entries: &[
                wgpu::BindGroupEntry {
                    binding: 0,
                    resource: wgpu::BindingResource::TextureView(a),
                },
                wgpu::BindGroupEntry {
                    binding: 1,
                    resource: wgpu::BindingResource::TextureView(b),
                },
                wgpu::BindGroupEntry {
                    binding: 2,
                    resource: self.options.as_entire_binding(),
                },
            ],
        }));
        Ok(())
    }

    /// Draws the compared material as the last [`Self::prepare_material`] rendered it.
    pub fn paint_material(&self, render_pass: &mut wgpu::RenderPass<'_>) {
        self.material.paint(render_pass);
    }

    /// Draws the difference the last [`Self::prepare_difference`] bound.
    pub fn paint_difference(&self, render_pass: &mut wgpu::RenderPass<'_>) {
        if let Some(bind_group) = &self.bind_group {
            render_pass.set_pipeline(&self.pipeline);
            render_pass.set_bind_group(0, bind_group, &[]);
            render_pass.draw(0..3, 0..1);
        }
    }

    /// The error of the last compare callback's prepare, if it failed.
    pub fn last_error(&self) -> Option<&str> {
        self.last_error.as_deref()
    }
}

/// Which picture a [`CompareCallback`] draws.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum ComparePane {
    /// The compared material.
    Material,
    /// The difference, saturating at ± this many stops.
    Difference { stops: f32 },
}

/// One pane of the compare mode, drawn over its rectangle.
#[derive(Clone, Debug)]
pub struct CompareCallback {
    pub frame: PreviewFrame,
    pub size: [u32; 2],
    pub pane: ComparePane,
}

impl egui_wgpu::CallbackTrait for CompareCallback {
    fn prepare(
        &self,
        device: &wgpu::Device,
        queue: &wgpu::Queue,
        _screen_descriptor: &egui_wgpu::ScreenDescriptor,
        _egui_encoder: &mut wgpu::CommandEncoder,
        resources: &mut egui_wgpu::CallbackResources,
    ) -> Vec<wgpu::CommandBuffer> {
        // Both renderers at once: the compare one leaves the map while the main one is used.
        let Some(mut compare) = resources.remove::<CompareRenderer>() else {
            return Vec::new();
        };
        let result = match self.pane {
            ComparePane::Material => {
                compare.prepare_material(device, queue, &self.frame, self.size)
            }
            ComparePane::Difference { stops } => match resources.get_mut::<PreviewRenderer>() {
                Some(main) => {
                    compare.prepare_difference(device, queue, main, &self.frame, self.size, stops)
                }
                None => Err(PreviewError::Missing("no preview renderer is installed")),
            },
        };
        compare.last_error = result.err().map(|e| e.to_string());
        resources.insert(compare);
        Vec::new()
    }

    fn paint(
        &self,
        _info: egui::PaintCallbackInfo,
        render_pass: &mut wgpu::RenderPass<'static>,
        resources: &egui_wgpu::CallbackResources,
    ) {
        if let Some(compare) = resources.get::<CompareRenderer>()
            && compare.last_error.is_none()
        {
            match self.pane {
                ComparePane::Material => compare.paint_material(render_pass),
                ComparePane::Difference { .. } => compare.paint_difference(render_pass),
            }
        }
    }
}

/// The compare pane `pane` of `frame` over `rect`, for `ui.painter().add(...)`.
pub fn compare_callback(
    rect: egui::Rect,
    pixels_per_point: f32,
    frame: PreviewFrame,
    pane: ComparePane,
) -> egui::PaintCallback {
    egui_wgpu::Callback::new_paint_callback(
        rect,
        CompareCallback {
            frame,
            size: super::physical_size(rect, pixels_per_point),
            pane,
        },
    )
}

/// Runs `f` on the compare renderer, creating it (once, beside the installed preview
/// renderer) when it is first needed; `None` if no preview renderer is installed.
pub fn with_compare<R>(
    render_state: &egui_wgpu::RenderState,
    f: impl FnOnce(&mut CompareRenderer) -> R,
) -> Result<Option<R>, PreviewError> {
    let mut renderer = render_state.renderer.write();
    let resources = &mut renderer.callback_resources;
    if resources.get::<CompareRenderer>().is_none() {
        let Some(main) = resources.get::<PreviewRenderer>() else {
            return Ok(None);
        };
        let compare = CompareRenderer::new(&render_state.device, &render_state.queue, main)?;
        resources.insert(compare);
    }
    Ok(resources.get_mut::<CompareRenderer>().map(f))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_difference_scale_is_black_at_zero_and_cool_below_warm_above() {
        assert_eq!(difference_colour(0.0), [0.0; 3]);
        let below = difference_colour(-1.0);
        let above = difference_colour(1.0);
        assert!(below[2] > below[0], "darker is blue: {below:?}");
        assert!(above[0] > above[2], "brighter is orange: {above:?}");
        assert_eq!(difference_colour(-7.0), below, "saturates");
    }
}
