//! The preview's GPU side: buffers, pipelines and passes.
//!
//! [`PreviewRenderer`] and the state it keeps are here, with the uploads of an object, a
//! table and an environment; each other job has its file: the pipelines (`pipelines`), the
//! basis and its coefficients (`basis_upload`), the sparse bins (`sparse`), the frame's
//! passes and their cache (`passes`), and reading results back (`readback`).

mod basis_upload;
mod passes;
mod pipelines;
mod readback;
mod sparse;

use super::PreviewError;
use super::environment::{Environment, EnvironmentSample};
use super::frame::{EnvironmentLight, FrameUniforms, PreviewFrame, SHADOW_MAP_SIZE};
use crate::scene::Object;
use crate::table::{PAIRS, SymTable};
use pipelines::Pipelines;
use sparse::SPARSE_WORDS;
use wgpu::util::DeviceExt;

/// The radiance the gather pass writes: linear, unclamped, exact enough to compare with the
/// CPU. The geometry raster's position and normal targets use it too.
const RADIANCE_FORMAT: wgpu::TextureFormat = wgpu::TextureFormat::Rgba32Float;
const DEPTH_FORMAT: wgpu::TextureFormat = wgpu::TextureFormat::Depth32Float;
/// Directions the environment light is sampled at. Each costs every pixel a table read per
/// gather, so this is what a new snapshot can afford on a software rasteriser (a draft uses
/// the first quarter); a glossy material shows the softboxes as clusters of glints.
pub const ENVIRONMENT_DIRECTIONS: usize = 64;

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
    /// Per pair the map's constants, then per pair a fitted reference's offsets.
    ranges: wgpu::Buffer,
    /// The fitted reference whose offsets `ranges` holds (`None`: zeros).
    fitted: Option<std::sync::Arc<crate::solver::FittedReference>>,
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

    pipelines: Pipelines,

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

fn buffer_entry(binding: u32, buffer: &wgpu::Buffer) -> wgpu::BindGroupEntry<'_> {
    wgpu::BindGroupEntry {
        binding,
        resource: buffer.as_entire_binding(),
    }
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
        let pipelines = Pipelines::new(device, layout)?;
        let FixedResources {
            frame_uniforms,
            raster_bind_group,
            present_options,
            shadow_view,
            shadow_sampler,
            empty_values,
            empty_marks,
            sparse,
            environment_buffer,
        } = FixedResources::new(device, layout, &pipelines.layouts.raster, sparse_bytes)?;
        let environment = Environment::studio();
        let environment_samples = environment.samples(ENVIRONMENT_DIRECTIONS);
        Ok(Self {
            device: device.clone(),
            queue: queue.clone(),
            limits,
            layout,
            pipelines,
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

    /// The passes `prepare` has run so far.
    pub fn pass_counts(&self) -> PassCounts {
        self.counts
    }
}

/// The buffers, shadow map and bind group made once with the renderer.
struct FixedResources {
    frame_uniforms: wgpu::Buffer,
    raster_bind_group: wgpu::BindGroup,
    present_options: wgpu::Buffer,
    shadow_view: wgpu::TextureView,
    shadow_sampler: wgpu::Sampler,
    empty_values: wgpu::Buffer,
    empty_marks: wgpu::Buffer,
    sparse: wgpu::Buffer,
    environment_buffer: wgpu::Buffer,
}

impl FixedResources {
    fn new(
        device: &wgpu::Device,
        layout: TargetLayout,
        raster_layout: &wgpu::BindGroupLayout,
        sparse_bytes: u64,
    ) -> Result<Self, PreviewError> {
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
            layout: raster_layout,
            entries: &[buffer_entry(0, &frame_uniforms)],
        });
        Ok(Self {
            frame_uniforms,
            raster_bind_group,
            present_options,
            shadow_view,
            shadow_sampler,
            empty_values,
            empty_marks,
            sparse,
            environment_buffer,
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
