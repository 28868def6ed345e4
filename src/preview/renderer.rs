//! The preview's GPU side: buffers, pipelines and passes.

use super::PreviewError;
use super::environment::{Environment, EnvironmentSample};
use super::frame::{EnvironmentLight, FrameUniforms, PreviewFrame, PreviewMode, SHADOW_MAP_SIZE};
use crate::basis::{Basis, MAP_EPSILON, RANGE_MARGIN, cos_weight_polar};
use crate::image_io::RgbImage;
use crate::scene::Object;
use crate::solver::{BANDS, pair_bands};
use crate::table::{PAIRS, SymTable, THETA_BINS};
use half::f16;
use rayon::prelude::*;
use wgpu::util::DeviceExt;

/// The radiance the gather pass writes: linear, unclamped, exact enough to compare with the
/// CPU. The geometry raster's position and normal targets use it too.
const RADIANCE_FORMAT: wgpu::TextureFormat = wgpu::TextureFormat::Rgba32Float;
const DEPTH_FORMAT: wgpu::TextureFormat = wgpu::TextureFormat::Depth32Float;
/// u32 words per pixel of the geometry record (`RECORD` in shaders/shade.wgsl).
const RECORD_WORDS: u64 = 20;
/// Side of the set-up and gather passes' workgroups (shaders/shade.wgsl).
const PIXEL_TILE: u32 = 8;
/// Directions the environment light is sampled at. Each costs every pixel a table read per
/// gather, so this is what a new snapshot can afford on a software rasteriser (a draft uses
/// the first quarter); a glossy material shows the softboxes as clusters of glints.
pub const ENVIRONMENT_DIRECTIONS: usize = 64;
/// Invocations per workgroup of the reconstruction pass (shaders/reconstruct.wgsl).
const WORKGROUP_SIZE: u32 = 256;
/// Pairs packed and uploaded at a time when a basis is set, to bound the staging memory.
const UPLOAD_CHUNK_PAIRS: usize = 1 << 16;
/// Changed sparse pairs closer than this are uploaded as one run (8 bytes per pair).
const SPARSE_MERGE_GAP: usize = 32;
/// u32 words per pair in the sparse buffer: pack2x16float(r, g), pack2x16float(b, observed).
const SPARSE_WORDS: usize = 2;
/// The observed flag: f16 1.0 in the high half of a pair's second word.
const OBSERVED_BITS: u32 = 0x3C00 << 16;

/// What the caller's render pass looks like, so that [`PreviewRenderer::paint`] can draw in it.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct TargetLayout {
    pub format: wgpu::TextureFormat,
    /// MSAA samples of the pass (1: none).
    pub samples: u32,
    /// The pass's depth-stencil format, if it has one (the preview neither tests nor writes it).
    pub depth_format: Option<wgpu::TextureFormat>,
}

impl TargetLayout {
    /// A single-sampled pass without depth: eframe's default.
    pub fn plain(format: wgpu::TextureFormat) -> Self {
        Self {
            format,
            samples: 1,
            depth_format: None,
        }
    }
}
/// Vertex and index buffers of a mesh object.
struct GpuMesh {
    vertices: wgpu::Buffer,
    indices: wgpu::Buffer,
    index_count: u32,
}

/// A basis on the GPU and the reconstruction it evaluates.
struct GpuBasis {
    components: usize,
    /// Components were stored multiplied by this power of two (see [`component_scale`]).
    scale: f32,
    coefficients: wgpu::Buffer,
    /// ρ per pair, 3 floats each, written by the reconstruction pass.
    output: wgpu::Buffer,
    bind_group: wgpu::BindGroup,
    workgroups: (u32, u32),
    /// Per pair, non-zero where the scene pass read the reconstruction.
    marked: wgpu::Buffer,
    /// The marked pairs' count and indirect dispatch size (shaders/view_pairs.wgsl).
    listed_counts: wgpu::Buffer,
    pairs_bind_group: wgpu::BindGroup,
}
/// What the geometry records of a frame depend on: the frame without the settings that only
/// scale or surround the picture, its size, the object and the environment. Painting changes
/// none of it, so a new snapshot re-runs only the gather pass.
#[derive(Clone, Debug, PartialEq)]
struct GeometryKey {
    frame: PreviewFrame,
    size: [u32; 2],
    object_generation: u64,
    environment_generation: u64,
}

impl GeometryKey {
    fn new(
        frame: &PreviewFrame,
        size: [u32; 2],
        object_generation: u64,
        environment_generation: u64,
    ) -> Self {
        let mut frame = frame.clone();
        frame.exposure_stops = 0.0;
        frame.background = [0.0; 3];
        frame.draft = false;
        Self {
            frame,
            size,
            object_generation,
            environment_generation,
        }
    }
}

/// What the radiance texture shows: the frame, and the generation of the values it read.
#[derive(Clone, Debug, PartialEq)]
struct ShadeKey {
    frame: PreviewFrame,
    size: [u32; 2],
    values_generation: u64,
}

/// How much of the reconstruction a frame re-evaluates.
#[derive(Clone, Copy, Debug, PartialEq)]
enum Evaluation {
    /// Only the pairs the view reads (listed by the set-up pass).
    Listed,
    /// Every pair.
    All,
}

/// The off-screen targets of one size: the geometry raster's position, normal and depth,
/// the per-pixel records, and the radiance the gather pass writes.
struct Target {
    size: [u32; 2],
    position_view: wgpu::TextureView,
    normal_view: wgpu::TextureView,
    depth_view: wgpu::TextureView,
    records: wgpu::Buffer,
    radiance: wgpu::Texture,
    radiance_view: wgpu::TextureView,
    present_bind_group: wgpu::BindGroup,
}

/// How many times [`PreviewRenderer::prepare`] ran each kind of pass: what caching saved.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct PassCounts {
    /// Geometry raster and per-pixel set-up (camera, lights, object, environment or size).
    pub geometry: u64,
    /// Reconstruction of the pairs the view reads (new coefficients or a new view).
    pub evaluations: u64,
    /// Gather passes: frames actually drawn.
    pub gathers: u64,
}

/// The object seen in the last shadow pass: light direction and object generation.
type ShadowKey = ([f32; 3], u64);

/// The environment as uploaded: generation, rotation and intensity bits.
type EnvironmentKey = (u64, u64, u64);

/// Draws an object with a tabulated BRDF; see the module documentation.
///
/// The renderer keeps clones of the device and queue it was made with (cheap handles) for its
/// setters; `prepare` and the readbacks must be given that same device and queue.
pub struct PreviewRenderer {
    device: wgpu::Device,
    queue: wgpu::Queue,
    limits: wgpu::Limits,
    layout: TargetLayout,

    shade_layout: wgpu::BindGroupLayout,
    compute_layout: wgpu::BindGroupLayout,
    present_layout: wgpu::BindGroupLayout,
    sphere_pipeline: wgpu::RenderPipeline,
    mesh_pipeline: wgpu::RenderPipeline,
    shadow_pipeline: wgpu::RenderPipeline,
    setup_pipeline: wgpu::ComputePipeline,
    gather_pipeline: wgpu::ComputePipeline,
    draft_pipeline: wgpu::ComputePipeline,
    compute_pipeline: wgpu::ComputePipeline,
    listed_pipeline: wgpu::ComputePipeline,
    pairs_layout: wgpu::BindGroupLayout,
    compact_pipeline: wgpu::ComputePipeline,
    size_dispatch_pipeline: wgpu::ComputePipeline,
    present_pipeline: wgpu::RenderPipeline,

    frame_uniforms: wgpu::Buffer,
    raster_bind_group: wgpu::BindGroup,
    present_options: wgpu::Buffer,
    shadow_view: wgpu::TextureView,
    shadow_sampler: wgpu::Sampler,
    /// Bound as the table in modes that read none.
    empty_values: wgpu::Buffer,
    /// Bound as the pair marks when there is no basis (nothing is marked then).
    empty_marks: wgpu::Buffer,

    mesh: Option<GpuMesh>,
    object_generation: u64,
    shadow_key: Option<ShadowKey>,
    basis: Option<GpuBasis>,
    /// The coefficients changed since the reconstruction was last evaluated.
    reconstruction_stale: bool,
    /// Every pair holds the current coefficients' value (not only the listed ones).
    reconstruction_complete: bool,
    /// The basis's marks and list hold the pairs of the current geometry.
    listed: bool,
    /// The geometry the records were set up for.
    geometry_key: Option<GeometryKey>,
    /// What the radiance texture holds.
    shaded: Option<ShadeKey>,
    /// Bumped whenever any ρ a frame may read changes (coefficients, sparse bins, table).
    values_generation: u64,
    table: Option<wgpu::Buffer>,
    sparse: wgpu::Buffer,
    /// The sparse buffer's contents, so that changed runs can be uploaded whole.
    sparse_words: Vec<u32>,
    environment: Environment,
    environment_samples: Vec<EnvironmentSample>,
    environment_generation: u64,
    /// Directions as rotated and scaled for the GPU, two vec4 each.
    environment_buffer: wgpu::Buffer,
    uploaded_environment: Option<EnvironmentKey>,
    target: Option<Target>,
    last_error: Option<String>,
    counts: PassCounts,
}

/// Creates buffers and textures under an out-of-memory error scope, so that a device that
/// cannot hold them gives an error rather than a panic.
fn allocate<T>(device: &wgpu::Device, f: impl FnOnce() -> T) -> Result<T, PreviewError> {
    let scope = device.push_error_scope(wgpu::ErrorFilter::OutOfMemory);
    let value = f();
    match pollster::block_on(scope.pop()) {
        Some(error) => Err(PreviewError::Gpu(error.to_string())),
        None => Ok(value),
    }
}

fn storage_entry(
    binding: u32,
    visibility: wgpu::ShaderStages,
    read_only: bool,
) -> wgpu::BindGroupLayoutEntry {
    wgpu::BindGroupLayoutEntry {
        binding,
        visibility,
        ty: wgpu::BindingType::Buffer {
            ty: wgpu::BufferBindingType::Storage { read_only },
            has_dynamic_offset: false,
            min_binding_size: None,
        },
        count: None,
    }
}

fn uniform_entry(binding: u32, visibility: wgpu::ShaderStages) -> wgpu::BindGroupLayoutEntry {
    wgpu::BindGroupLayoutEntry {
        binding,
        visibility,
        ty: wgpu::BindingType::Buffer {
            ty: wgpu::BufferBindingType::Uniform,
            has_dynamic_offset: false,
            min_binding_size: None,
        },
        count: None,
    }
}

fn buffer_entry(binding: u32, buffer: &wgpu::Buffer) -> wgpu::BindGroupEntry<'_> {
    wgpu::BindGroupEntry {
        binding,
        resource: buffer.as_entire_binding(),
    }
}

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
    /// A renderer that paints into single-sampled passes without depth of `target_format`.
    pub fn new(
        device: &wgpu::Device,
        queue: &wgpu::Queue,
        target_format: wgpu::TextureFormat,
    ) -> Result<Self, PreviewError> {
        Self::with_layout(device, queue, TargetLayout::plain(target_format))
    }

    /// A renderer that paints into passes of the given layout.
    pub fn with_layout(
        device: &wgpu::Device,
        queue: &wgpu::Queue,
        layout: TargetLayout,
    ) -> Result<Self, PreviewError> {
        let limits = device.limits();
        let sparse_bytes = (PAIRS * SPARSE_WORDS * 4) as u64;
        let table_bytes = (PAIRS * 3 * 4) as u64;
        check_fits(&limits, "the sparse bins", sparse_bytes)?;
        check_fits(&limits, "a table", table_bytes)?;

        let validation = device.push_error_scope(wgpu::ErrorFilter::Validation);
        let scene_module = device.create_shader_module(wgpu::ShaderModuleDescriptor {
            label: Some("preview geometry"),
            source: wgpu::ShaderSource::Wgsl(
                concat!(
                    include_str!("../../shaders/frame.wgsl"),
                    include_str!("../../shaders/preview.wgsl")
                )
                .into(),
            ),
        });
        let shade_module = device.create_shader_module(wgpu::ShaderModuleDescriptor {
            label: Some("preview shading"),
            source: wgpu::ShaderSource::Wgsl(
                concat!(
                    include_str!("../../shaders/frame.wgsl"),
                    include_str!("../../shaders/shade.wgsl")
                )
                .into(),
            ),
        });
        let compute_module = device.create_shader_module(wgpu::ShaderModuleDescriptor {
            label: Some("preview reconstruction"),
            source: wgpu::ShaderSource::Wgsl(include_str!("../../shaders/reconstruct.wgsl").into()),
        });
        let pairs_module = device.create_shader_module(wgpu::ShaderModuleDescriptor {
            label: Some("preview view pairs"),
            source: wgpu::ShaderSource::Wgsl(include_str!("../../shaders/view_pairs.wgsl").into()),
        });
        let present_module = device.create_shader_module(wgpu::ShaderModuleDescriptor {
            label: Some("preview present"),
            source: wgpu::ShaderSource::Wgsl(include_str!("../../shaders/present.wgsl").into()),
        });

        let fragment = wgpu::ShaderStages::FRAGMENT;
        let compute = wgpu::ShaderStages::COMPUTE;
        let raster_layout = device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
            label: Some("preview geometry"),
            entries: &[uniform_entry(0, wgpu::ShaderStages::VERTEX | fragment)],
        });
        let float_texture = |binding, sample_type| wgpu::BindGroupLayoutEntry {
            binding,
            visibility: compute,
            ty: wgpu::BindingType::Texture {
                sample_type,
                view_dimension: wgpu::TextureViewDimension::D2,
                multisampled: false,
            },
            count: None,
        };
        let unfilterable = wgpu::TextureSampleType::Float { filterable: false };
        let shade_layout = device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
            label: Some("preview shading"),
            entries: &[
                uniform_entry(0, compute),
                storage_entry(1, compute, true),
                storage_entry(2, compute, true),
                float_texture(3, unfilterable),
                float_texture(4, unfilterable),
                float_texture(5, wgpu::TextureSampleType::Depth),
                wgpu::BindGroupLayoutEntry {
                    binding: 6,
                    visibility: compute,
                    ty: wgpu::BindingType::Sampler(wgpu::SamplerBindingType::Comparison),
                    count: None,
                },
                storage_entry(7, compute, false),
                storage_entry(8, compute, false),
                storage_entry(9, compute, true),
                wgpu::BindGroupLayoutEntry {
                    binding: 10,
                    visibility: compute,
                    ty: wgpu::BindingType::StorageTexture {
                        access: wgpu::StorageTextureAccess::WriteOnly,
                        format: RADIANCE_FORMAT,
                        view_dimension: wgpu::TextureViewDimension::D2,
                    },
                    count: None,
                },
            ],
        });
        let compute_layout = device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
            label: Some("preview reconstruction"),
            entries: &[
                uniform_entry(0, compute),
                storage_entry(1, compute, true),
                storage_entry(2, compute, true),
                storage_entry(3, compute, true),
                storage_entry(4, compute, true),
                storage_entry(5, compute, false),
                storage_entry(6, compute, true),
                storage_entry(7, compute, true),
                storage_entry(8, compute, true),
            ],
        });
        let pairs_layout = device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
            label: Some("preview view pairs"),
            entries: &[
                uniform_entry(0, compute),
                storage_entry(1, compute, true),
                storage_entry(2, compute, false),
                storage_entry(3, compute, false),
            ],
        });
        let present_layout = device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
            label: Some("preview present"),
            entries: &[
                wgpu::BindGroupLayoutEntry {
                    binding: 0,
                    visibility: fragment,
                    ty: wgpu::BindingType::Texture {
                        sample_type: wgpu::TextureSampleType::Float { filterable: false },
                        view_dimension: wgpu::TextureViewDimension::D2,
                        multisampled: false,
                    },
                    count: None,
                },
                uniform_entry(1, fragment),
            ],
        });

        let pipeline_layout = |layout: &wgpu::BindGroupLayout, label: &str| {
            device.create_pipeline_layout(&wgpu::PipelineLayoutDescriptor {
                label: Some(label),
                bind_group_layouts: &[Some(layout)],
                immediate_size: 0,
            })
        };
        let scene_pipeline_layout = pipeline_layout(&raster_layout, "preview geometry");
        let shade_pipeline_layout = pipeline_layout(&shade_layout, "preview shading");
        let compute_pipeline_layout = pipeline_layout(&compute_layout, "preview reconstruction");
        let pairs_pipeline_layout = pipeline_layout(&pairs_layout, "preview view pairs");
        let present_pipeline_layout = pipeline_layout(&present_layout, "preview present");

        let mesh_buffers = [Some(wgpu::VertexBufferLayout {
            array_stride: 6 * 4,
            step_mode: wgpu::VertexStepMode::Vertex,
            attributes: &wgpu::vertex_attr_array![0 => Float32x3, 1 => Float32x3],
        })];
        let depth_state = |compare| {
            Some(wgpu::DepthStencilState {
                format: DEPTH_FORMAT,
                depth_write_enabled: Some(true),
                depth_compare: Some(compare),
                stencil: wgpu::StencilState::default(),
                bias: wgpu::DepthBiasState::default(),
            })
        };
        // World position (w: 1 on the object) and unit normal.
        let geometry_target = Some(wgpu::ColorTargetState {
            format: RADIANCE_FORMAT,
            blend: None,
            write_mask: wgpu::ColorWrites::ALL,
        });
        let geometry_targets = [geometry_target.clone(), geometry_target];
        // Open meshes (a bowl) show their inside: no culling, as the CPU ray caster.
        let primitive = wgpu::PrimitiveState::default();
        let scene_pipeline =
            |label: &str,
             vertex_entry: &str,
             fragment_entry: &str,
             buffers: &[Option<wgpu::VertexBufferLayout>]| {
                device.create_render_pipeline(&wgpu::RenderPipelineDescriptor {
                    label: Some(label),
                    layout: Some(&scene_pipeline_layout),
                    vertex: wgpu::VertexState {
                        module: &scene_module,
                        entry_point: Some(vertex_entry),
                        compilation_options: Default::default(),
                        buffers,
                    },
                    primitive,
                    depth_stencil: depth_state(wgpu::CompareFunction::Less),
                    multisample: wgpu::MultisampleState::default(),
                    fragment: Some(wgpu::FragmentState {
                        module: &scene_module,
                        entry_point: Some(fragment_entry),
                        compilation_options: Default::default(),
                        targets: &geometry_targets,
                    }),
                    multiview_mask: None,
                    cache: None,
                })
            };
        let sphere_pipeline = scene_pipeline("preview sphere", "vs_fullscreen", "fs_sphere", &[]);
        let mesh_pipeline = scene_pipeline("preview mesh", "vs_mesh", "fs_mesh", &mesh_buffers);
        let shadow_pipeline = device.create_render_pipeline(&wgpu::RenderPipelineDescriptor {
            label: Some("preview shadow"),
            layout: Some(&scene_pipeline_layout),
            vertex: wgpu::VertexState {
                module: &scene_module,
                entry_point: Some("vs_shadow"),
                compilation_options: Default::default(),
                buffers: &mesh_buffers,
            },
            primitive,
            depth_stencil: depth_state(wgpu::CompareFunction::Less),
            multisample: wgpu::MultisampleState::default(),
            fragment: None,
            multiview_mask: None,
            cache: None,
        });
        let compute_pipeline =
            |label: &str, layout: &wgpu::PipelineLayout, module, entry_point: &str| {
                device.create_compute_pipeline(&wgpu::ComputePipelineDescriptor {
                    label: Some(label),
                    layout: Some(layout),
                    module,
                    entry_point: Some(entry_point),
                    compilation_options: Default::default(),
                    cache: None,
                })
            };
        let listed_pipeline = compute_pipeline(
            "preview reconstruction of listed pairs",
            &compute_pipeline_layout,
            &compute_module,
            "reconstruct_listed",
        );
        let compact_pipeline = compute_pipeline(
            "preview view pairs",
            &pairs_pipeline_layout,
            &pairs_module,
            "compact",
        );
        let size_dispatch_pipeline = compute_pipeline(
            "preview view pairs dispatch",
            &pairs_pipeline_layout,
            &pairs_module,
            "size_dispatch",
        );
        let setup_pipeline = compute_pipeline(
            "preview set-up",
            &shade_pipeline_layout,
            &shade_module,
            "setup",
        );
        let gather_pipeline = compute_pipeline(
            "preview gather",
            &shade_pipeline_layout,
            &shade_module,
            "gather",
        );
        let draft_pipeline = compute_pipeline(
            "preview draft gather",
            &shade_pipeline_layout,
            &shade_module,
            "gather_draft",
        );
        let compute_pipeline = compute_pipeline(
            "preview reconstruction",
            &compute_pipeline_layout,
            &compute_module,
            "reconstruct",
        );
        let present_pipeline = device.create_render_pipeline(&wgpu::RenderPipelineDescriptor {
            label: Some("preview present"),
            layout: Some(&present_pipeline_layout),
            vertex: wgpu::VertexState {
                module: &present_module,
                entry_point: Some("vs_present"),
                compilation_options: Default::default(),
                buffers: &[],
            },
            primitive,
            depth_stencil: layout.depth_format.map(|format| wgpu::DepthStencilState {
                format,
                depth_write_enabled: Some(false),
                depth_compare: Some(wgpu::CompareFunction::Always),
                stencil: wgpu::StencilState::default(),
                bias: wgpu::DepthBiasState::default(),
            }),
            multisample: wgpu::MultisampleState {
                count: layout.samples.max(1),
                ..Default::default()
            },
            fragment: Some(wgpu::FragmentState {
                module: &present_module,
                entry_point: Some("fs_present"),
                compilation_options: Default::default(),
                targets: &[Some(wgpu::ColorTargetState {
                    format: layout.format,
                    blend: None,
                    write_mask: wgpu::ColorWrites::ALL,
                })],
            }),
            multiview_mask: None,
            cache: None,
        });
        if let Some(error) = pollster::block_on(validation.pop()) {
            return Err(PreviewError::Gpu(format!(
                "the preview's pipelines could not be created for {layout:?}: {error}"
            )));
        }

        let environment = Environment::studio();
        let environment_samples = environment.samples(ENVIRONMENT_DIRECTIONS);
        let (frame_uniforms, present_options, empty_values, sparse, shadow_texture) =
            allocate(device, || {
                let frame_uniforms = device.create_buffer(&wgpu::BufferDescriptor {
                    label: Some("preview frame"),
                    size: std::mem::size_of::<FrameUniforms>() as u64,
                    usage: wgpu::BufferUsages::UNIFORM | wgpu::BufferUsages::COPY_DST,
                    mapped_at_creation: false,
                });
                let encode = u32::from(!layout.format.is_srgb());
                let present_options =
                    device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
                        label: Some("preview present options"),
                        contents: bytemuck::cast_slice(&[encode, 0, 0, 0]),
                        usage: wgpu::BufferUsages::UNIFORM,
                    });
                let empty_values = device.create_buffer(&wgpu::BufferDescriptor {
                    label: Some("preview no table"),
                    size: 16,
                    usage: wgpu::BufferUsages::STORAGE,
                    mapped_at_creation: false,
                });
                // Zeroed: every bin unobserved.
                let sparse = device.create_buffer(&wgpu::BufferDescriptor {
                    label: Some("preview sparse bins"),
                    size: sparse_bytes,
                    usage: wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_DST,
                    mapped_at_creation: false,
                });
                let shadow_texture = device.create_texture(&wgpu::TextureDescriptor {
                    label: Some("preview shadow map"),
                    size: wgpu::Extent3d {
                        width: SHADOW_MAP_SIZE,
                        height: SHADOW_MAP_SIZE,
                        depth_or_array_layers: 1,
                    },
                    mip_level_count: 1,
                    sample_count: 1,
                    dimension: wgpu::TextureDimension::D2,
                    format: DEPTH_FORMAT,
                    usage: wgpu::TextureUsages::RENDER_ATTACHMENT
                        | wgpu::TextureUsages::TEXTURE_BINDING,
                    view_formats: &[],
                });
                (
                    frame_uniforms,
                    present_options,
                    empty_values,
                    sparse,
                    shadow_texture,
                )
            })?;
        let (empty_marks, environment_buffer) = allocate(device, || {
            (
                device.create_buffer(&wgpu::BufferDescriptor {
                    label: Some("preview no pair marks"),
                    size: 16,
                    usage: wgpu::BufferUsages::STORAGE,
                    mapped_at_creation: false,
                }),
                device.create_buffer(&wgpu::BufferDescriptor {
                    label: Some("preview environment directions"),
                    size: (ENVIRONMENT_DIRECTIONS * 32) as u64,
                    usage: wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_DST,
                    mapped_at_creation: false,
                }),
            )
        })?;
        let shadow_view = shadow_texture.create_view(&Default::default());
        let shadow_sampler = device.create_sampler(&wgpu::SamplerDescriptor {
            label: Some("preview shadow"),
            mag_filter: wgpu::FilterMode::Linear,
            min_filter: wgpu::FilterMode::Linear,
            compare: Some(wgpu::CompareFunction::LessEqual),
            ..Default::default()
        });
        let raster_bind_group = device.create_bind_group(&wgpu::BindGroupDescriptor {
            label: Some("preview geometry"),
            layout: &raster_layout,
            entries: &[buffer_entry(0, &frame_uniforms)],
        });

        Ok(Self {
            device: device.clone(),
            queue: queue.clone(),
            limits,
            layout,
            shade_layout,
            compute_layout,
            present_layout,
            sphere_pipeline,
            mesh_pipeline,
            shadow_pipeline,
            setup_pipeline,
            gather_pipeline,
            draft_pipeline,
            compute_pipeline,
            listed_pipeline,
            pairs_layout,
            compact_pipeline,
            size_dispatch_pipeline,
            present_pipeline,
            frame_uniforms,
            raster_bind_group,
            present_options,
            shadow_view,
            shadow_sampler,
            empty_values,
            empty_marks,
            mesh: None,
            object_generation: 0,
            shadow_key: None,
            basis: None,
            reconstruction_stale: false,
            reconstruction_complete: false,
            listed: false,
            geometry_key: None,
            shaded: None,
            values_generation: 0,
            table: None,
            sparse,
            sparse_words: vec![0; PAIRS * SPARSE_WORDS],
            environment,
            environment_samples,
            environment_generation: 0,
            environment_buffer,
            uploaded_environment: None,
            target: None,
            last_error: None,
            counts: PassCounts::default(),
        })
    }

    /// The layout of the passes [`Self::paint`] draws into.
    pub fn target_layout(&self) -> TargetLayout {
        self.layout
    }

    /// The object to draw: the analytic sphere is traced per pixel, meshes are rasterised.
    pub fn set_object(&mut self, object: &Object) -> Result<(), PreviewError> {
        self.object_generation += 1;
        self.shadow_key = None;
        let Some(mesh) = object.mesh() else {
            self.mesh = None;
            return Ok(());
        };
        let vertices: Vec<[f32; 6]> = mesh
            .positions
            .iter()
            .zip(&mesh.normals)
            .map(|(p, n)| {
                let (p, n) = (p.as_vec3(), n.as_vec3());
                [p.x, p.y, p.z, n.x, n.y, n.z]
            })
            .collect();
        let vertex_bytes: &[u8] = bytemuck::cast_slice(&vertices);
        let index_bytes: &[u8] = bytemuck::cast_slice(&mesh.triangles);
        for (what, bytes) in [
            ("the mesh's vertices", vertex_bytes),
            ("the mesh's faces", index_bytes),
        ] {
            if bytes.len() as u64 > self.limits.max_buffer_size {
                return Err(PreviewError::TooLarge {
                    what: what.into(),
                    bytes: bytes.len() as u64,
                    limit: self.limits.max_buffer_size,
                });
            }
        }
        let index_count = u32::try_from(mesh.triangles.len() * 3).map_err(|_| {
            PreviewError::Invalid(format!(
                "the mesh has {} faces, more than one draw call takes",
                mesh.triangles.len()
            ))
        })?;
        let device = &self.device;
        self.mesh = Some(allocate(device, || GpuMesh {
            vertices: device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
                label: Some("preview mesh vertices"),
                contents: vertex_bytes,
                usage: wgpu::BufferUsages::VERTEX,
            }),
            indices: device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
                label: Some("preview mesh indices"),
                contents: index_bytes,
                usage: wgpu::BufferUsages::INDEX,
            }),
            index_count,
        })?);
        Ok(())
    }

    /// Uploads a basis (once per basis): its components as f16 pairs, and per pair the
    /// reference, mean and mapped range. The coefficients start at zero (the mean material).
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
        check_fits(
            &self.limits,
            "the basis's per-pair ranges",
            (PAIRS * 16) as u64,
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
                buffer("preview basis ranges", (PAIRS * 16) as u64, usage),
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
            layout: &self.compute_layout,
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
            layout: &self.pairs_layout,
            entries: &[
                buffer_entry(0, &pairs_params),
                buffer_entry(1, &marked),
                buffer_entry(2, &listed),
                buffer_entry(3, &listed_counts),
            ],
        });
        self.queue
            .write_buffer(&coefficients, 0, &vec![0u8; coefficient_bytes as usize]);
        self.basis = Some(GpuBasis {
            components: k,
            scale,
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

    /// Sets (`Some(ρ)`) or forgets (`None`) observed bins for sparse mode; only the changed
    /// runs of the per-pair buffer are uploaded. Values are stored as f16 (ρ above 65504
    /// shows as 65504).
    pub fn update_sparse(
        &mut self,
        changes: &[(u32, Option<[f32; 3]>)],
    ) -> Result<(), PreviewError> {
        for &(pair, value) in changes {
            if pair as usize >= PAIRS {
                return Err(PreviewError::Invalid(format!(
                    "sparse bin pair {pair} is out of range (there are {PAIRS} pairs)"
                )));
            }
            if let Some(rgb) = value
                && rgb.iter().any(|c| !(c.is_finite() && *c >= 0.0))
            {
                return Err(PreviewError::Invalid(format!(
                    "sparse bin pair {pair} has ρ = {rgb:?}; it must be finite and ≥ 0"
                )));
            }
        }
        let mut changed: Vec<usize> = Vec::with_capacity(changes.len());
        for &(pair, value) in changes {
            let pair = pair as usize;
            let words = match value {
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

    /// Uploads a whole table for [`PreviewMode::Table`] (an imported table, or a test's).
    pub fn set_table(&mut self, table: &SymTable) -> Result<(), PreviewError> {
        if !table.is_physical() {
            return Err(PreviewError::Invalid(
                "the table has values that are negative or not finite".into(),
            ));
        }
        if self.table.is_none() {
            let device = &self.device;
            self.table = Some(allocate(device, || {
                device.create_buffer(&wgpu::BufferDescriptor {
                    label: Some("preview table"),
                    size: (PAIRS * 3 * 4) as u64,
                    usage: wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_DST,
                    mapped_at_creation: false,
                })
            })?);
        }
        let buffer = self.table.as_ref().expect("allocated above");
        self.queue
            .write_buffer(buffer, 0, bytemuck::cast_slice(table.pairs()));
        self.values_generation += 1;
        Ok(())
    }

    /// The environment the environment light samples (the bundled studio until another is
    /// set): [`ENVIRONMENT_DIRECTIONS`] directions are drawn from it here, once.
    pub fn set_environment(&mut self, environment: &Environment) {
        self.environment_samples = environment.samples(ENVIRONMENT_DIRECTIONS);
        self.environment = environment.clone();
        self.environment_generation += 1;
        self.uploaded_environment = None;
    }

    /// The environment the environment light samples.
    pub fn environment(&self) -> &Environment {
        &self.environment
    }

    /// Uploads the environment's directions turned by the frame's rotation and scaled by its
    /// intensity, unless they already are; how many the frame uses (0 without the light).
    fn upload_environment(&mut self, light: Option<&EnvironmentLight>) -> u32 {
        let Some(light) = light else {
            return 0;
        };
        let key = (
            self.environment_generation,
            light.rotation_deg.to_bits(),
            light.intensity.to_bits(),
        );
        if self.uploaded_environment != Some(key) {
            let (sin, cos) = light.rotation_deg.to_radians().sin_cos();
            let packed: Vec<[f32; 4]> = self
                .environment_samples
                .iter()
                .flat_map(|s| {
                    // About y, toward +x from +z (SCENE.md's azimuth).
                    let d = s.direction;
                    let turned = [d.x * cos + d.z * sin, d.y, d.z * cos - d.x * sin];
                    let w = s.weight.map(|c| c * light.intensity);
                    [
                        [turned[0] as f32, turned[1] as f32, turned[2] as f32, 0.0],
                        [w[0] as f32, w[1] as f32, w[2] as f32, 0.0],
                    ]
                })
                .collect();
            if !packed.is_empty() {
                self.queue
                    .write_buffer(&self.environment_buffer, 0, bytemuck::cast_slice(&packed));
            }
            self.uploaded_environment = Some(key);
        }
        self.environment_samples.len() as u32
    }

    /// The error of the last [`PreviewCallback`](super::PreviewCallback) prepare, if it failed
    /// (a paint callback has nowhere else to report it).
    pub fn last_error(&self) -> Option<&str> {
        self.last_error.as_deref()
    }

    pub(crate) fn set_last_error(&mut self, error: Option<String>) {
        self.last_error = error;
    }

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
            layout: &self.shade_layout,
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
            pass.set_pipeline(&self.setup_pipeline);
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
                pass.set_pipeline(&self.draft_pipeline);
                let blocks = (width.div_ceil(2), height.div_ceil(2));
                pass.dispatch_workgroups(
                    blocks.0.div_ceil(PIXEL_TILE),
                    blocks.1.div_ceil(PIXEL_TILE),
                    1,
                );
            } else {
                pass.set_pipeline(&self.gather_pipeline);
                pass.dispatch_workgroups(tiles.0, tiles.1, 1);
            }
        }
        queue.submit([encoder.finish()]);
        self.shaded = Some(shade_key);
        self.counts.gathers += 1;
        Ok(())
    }

    /// The passes `prepare` has run so far.
    pub fn pass_counts(&self) -> PassCounts {
        self.counts
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
            pass.set_pipeline(&self.shadow_pipeline);
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
                pass.set_pipeline(&self.sphere_pipeline);
                pass.draw(0..3, 0..1);
            }
            Some(mesh) => {
                pass.set_pipeline(&self.mesh_pipeline);
                pass.set_vertex_buffer(0, mesh.vertices.slice(..));
                pass.set_index_buffer(mesh.indices.slice(..), wgpu::IndexFormat::Uint32);
                pass.draw_indexed(0..mesh.index_count, 0, 0..1);
            }
        }
    }

    /// The linear radiance the last `prepare` drew, for passes that combine two renders.
    pub(super) fn radiance_view(&self) -> Option<&wgpu::TextureView> {
        self.target.as_ref().map(|t| &t.radiance_view)
    }

    pub fn paint(&self, render_pass: &mut wgpu::RenderPass<'_>) {
        if let Some(target) = &self.target {
            render_pass.set_pipeline(&self.present_pipeline);
            render_pass.set_bind_group(0, &target.present_bind_group, &[]);
            render_pass.draw(0..3, 0..1);
        }
    }

    /// Renders `frame` off screen and reads back its linear radiance (times 2^exposure,
    /// neither clamped nor encoded), rows from the top.
    pub fn render_to_image(
        &mut self,
        device: &wgpu::Device,
        queue: &wgpu::Queue,
        frame: &PreviewFrame,
        width: u32,
        height: u32,
    ) -> Result<RgbImage, PreviewError> {
        self.prepare(device, queue, frame, [width, height])?;
        let texels = self.read_texels(device, queue, [0, 0], [width, height])?;
        Ok(RgbImage {
            width: width as usize,
            height: height as usize,
            pixels: texels.iter().map(|t| [t[0], t[1], t[2]]).collect(),
        })
    }

    /// What `frame`, drawn at `size`, shows at `pixel` (from the top left): its linear
    /// radiance (times 2^exposure), or `None` where the pixel shows the background. Renders
    /// the frame off screen and reads back that one texel: for an eyedropper on the preview.
    pub fn pick(
        &mut self,
        device: &wgpu::Device,
        queue: &wgpu::Queue,
        frame: &PreviewFrame,
        size: [u32; 2],
        pixel: [u32; 2],
    ) -> Result<Option<[f32; 3]>, PreviewError> {
        if pixel[0] >= size[0] || pixel[1] >= size[1] {
            return Ok(None);
        }
        self.prepare(device, queue, frame, size)?;
        let [t] = self.read_texels(device, queue, pixel, [1, 1])?[..] else {
            unreachable!("one texel was read")
        };
        Ok((t[3] > 0.0).then_some([t[0], t[1], t[2]]))
    }

    /// Reads back a rectangle of the scene pass's colour target (RGBA f32), rows from the top.
    fn read_texels(
        &self,
        device: &wgpu::Device,
        queue: &wgpu::Queue,
        origin: [u32; 2],
        [width, height]: [u32; 2],
    ) -> Result<Vec<[f32; 4]>, PreviewError> {
        let target = self.target.as_ref().expect("prepared");
        let row_bytes = width * 16;
        let padded = row_bytes.next_multiple_of(wgpu::COPY_BYTES_PER_ROW_ALIGNMENT);
        let readback = allocate(device, || {
            device.create_buffer(&wgpu::BufferDescriptor {
                label: Some("preview readback"),
                size: padded as u64 * height as u64,
                usage: wgpu::BufferUsages::COPY_DST | wgpu::BufferUsages::MAP_READ,
                mapped_at_creation: false,
            })
        })?;
        let mut encoder = device.create_command_encoder(&wgpu::CommandEncoderDescriptor {
            label: Some("preview readback"),
        });
        encoder.copy_texture_to_buffer(
            wgpu::TexelCopyTextureInfo {
                origin: wgpu::Origin3d {
                    x: origin[0],
                    y: origin[1],
                    z: 0,
                },
                ..target.radiance.as_image_copy()
            },
            wgpu::TexelCopyBufferInfo {
                buffer: &readback,
                layout: wgpu::TexelCopyBufferLayout {
                    offset: 0,
                    bytes_per_row: Some(padded),
                    rows_per_image: None,
                },
            },
            wgpu::Extent3d {
                width,
                height,
                depth_or_array_layers: 1,
            },
        );
        queue.submit([encoder.finish()]);
        let bytes = read_buffer(device, &readback)?;
        let mut texels = Vec::with_capacity(width as usize * height as usize);
        for row in bytes.chunks_exact(padded as usize) {
            texels.extend_from_slice(bytemuck::cast_slice::<u8, [f32; 4]>(
                &row[..row_bytes as usize],
            ));
        }
        Ok(texels)
    }

    /// The table the GPU evaluated from the basis and coefficients (evaluating it first if
    /// the coefficients changed), read back: for checking the GPU against the engine.
    pub fn reconstruction_table(
        &mut self,
        device: &wgpu::Device,
        queue: &wgpu::Queue,
    ) -> Result<SymTable, PreviewError> {
        let size = (PAIRS * 3 * 4) as u64;
        let readback = allocate(device, || {
            device.create_buffer(&wgpu::BufferDescriptor {
                label: Some("preview reconstruction readback"),
                size,
                usage: wgpu::BufferUsages::COPY_DST | wgpu::BufferUsages::MAP_READ,
                mapped_at_creation: false,
            })
        })?;
        let mut encoder = device.create_command_encoder(&wgpu::CommandEncoderDescriptor {
            label: Some("preview reconstruction readback"),
        });
        if self.basis.is_none() {
            return Err(PreviewError::Missing("no basis has been set"));
        }
        if self.reconstruction_stale || !self.reconstruction_complete {
            self.encode_reconstruction(&mut encoder, Evaluation::All);
        }
        let basis = self.basis.as_ref().expect("checked above");
        encoder.copy_buffer_to_buffer(&basis.output, 0, &readback, 0, size);
        queue.submit([encoder.finish()]);
        let bytes = read_buffer(device, &readback)?;
        let values: Vec<[f32; 3]> = bytemuck::cast_slice(&bytes).to_vec();
        Ok(SymTable::from_pairs(values).expect("PAIRS values"))
    }

    /// How many pairs the last listing found the view reading (those new coefficients are
    /// evaluated for while the geometry stays); `None` before a reconstruction frame.
    pub fn view_pair_count(&self) -> Result<Option<u32>, PreviewError> {
        let (Some(basis), true) = (&self.basis, self.listed) else {
            return Ok(None);
        };
        let readback = allocate(&self.device, || {
            self.device.create_buffer(&wgpu::BufferDescriptor {
                label: Some("preview listed pair count readback"),
                size: 16,
                usage: wgpu::BufferUsages::COPY_DST | wgpu::BufferUsages::MAP_READ,
                mapped_at_creation: false,
            })
        })?;
        let mut encoder = self
            .device
            .create_command_encoder(&wgpu::CommandEncoderDescriptor {
                label: Some("preview listed pair count readback"),
            });
        encoder.copy_buffer_to_buffer(&basis.listed_counts, 0, &readback, 0, 16);
        self.queue.submit([encoder.finish()]);
        let bytes = read_buffer(&self.device, &readback)?;
        Ok(Some(bytemuck::cast_slice::<u8, u32>(&bytes)[0]))
    }

    /// Records the reconstruction pass over all pairs or over the listed ones.
    fn encode_reconstruction(
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
            pass.set_pipeline(&self.compute_pipeline);
            pass.dispatch_workgroups(basis.workgroups.0, basis.workgroups.1, 1);
        } else {
            pass.set_pipeline(&self.listed_pipeline);
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
        pass.set_pipeline(&self.compact_pipeline);
        pass.dispatch_workgroups(basis.workgroups.0, basis.workgroups.1, 1);
        pass.set_pipeline(&self.size_dispatch_pipeline);
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
            layout: &self.present_layout,
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

/// Errors unless a storage buffer of `bytes` fits the device's limits.
fn check_fits(limits: &wgpu::Limits, what: &str, bytes: u64) -> Result<(), PreviewError> {
    let limit = limits
        .max_storage_buffer_binding_size
        .min(limits.max_buffer_size);
    if bytes > limit {
        return Err(PreviewError::TooLarge {
            what: what.into(),
            bytes,
            limit,
        });
    }
    Ok(())
}

/// Maps a MAP_READ buffer whose copy was submitted, waits, and returns its bytes.
fn read_buffer(device: &wgpu::Device, buffer: &wgpu::Buffer) -> Result<Vec<u8>, PreviewError> {
    let (sender, receiver) = std::sync::mpsc::channel();
    buffer.map_async(wgpu::MapMode::Read, .., move |result| {
        // The receiver waits below; it cannot be gone.
        let _ = sender.send(result);
    });
    device
        .poll(wgpu::PollType::wait_indefinitely())
        .map_err(|e| PreviewError::Gpu(format!("waiting for the GPU: {e}")))?;
    receiver
        .recv()
        .map_err(|_| PreviewError::Gpu("the readback was never answered".into()))?
        .map_err(|e| PreviewError::Gpu(format!("mapping the readback: {e}")))?;
    let bytes = buffer
        .get_mapped_range(..)
        .map_err(|e| PreviewError::Gpu(format!("reading the readback: {e}")))?
        .to_vec();
    buffer.unmap();
    Ok(bytes)
}
