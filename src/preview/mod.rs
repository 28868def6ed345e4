//! The wgpu preview: the object drawn with the reconstructed BRDF, evaluated on the GPU.
//!
//! Data reaches the GPU only when it changes: the basis once per basis (components as f16
//! pairs, ~52 MB at K = 20), the K × 3 coefficients per snapshot (a compute pass then
//! evaluates ρ for every pair, exactly as `solver::Reconstruction::eval_pair`), sparse bins
//! pair by pair, a table once. Evaluating all 1,313,010 pairs once per new set of coefficients
//! costs 1.3 M × K multiply-adds, less than evaluating per fragment (16 interpolation taps per
//! pixel and light: 3.3 M pairs for a sphere at 512², and again every frame the camera moves).
//!
//! What painting does not change is cached. When the camera, lights, object or size change,
//! [`PreviewRenderer::prepare`] rasterises the object's positions and normals, renders the
//! shadow map, and a set-up pass stores per pixel its light and view bins, interpolation
//! fractions, cos θ_l × irradiance × shadow: a geometry buffer. A new snapshot then costs the
//! evaluation of the pairs that buffer reads and one gather pass, which writes linear radiance
//! (times the exposure) into the renderer's own `Rgba32Float` texture; with nothing changed,
//! `prepare` draws nothing. [`PreviewRenderer::paint`] copies that texture into the caller's
//! render pass, one texel per pixel, clamped to [0, 1] and sRGB-encoded unless the target
//! format is an `*Srgb` one (which encodes by itself). [`PreviewRenderer::render_to_image`]
//! reads the linear texture back instead.
//!
//! Besides the directional lights, an environment light samples an HDR equirectangular image
//! ([`Environment`]; the bundled studio is made here) at [`ENVIRONMENT_DIRECTIONS`]
//! directions through the same table. The object may be the painted view's or any other
//! ([`PreviewObject`], with the [`material_test_object`] made here).
//!
//! Radiance follows TABLE.md: a directional light of irradiance π gives π · ρ · cos θ_l, no
//! light below the horizon, bins and shading frames exactly as `scene::render_table` uses them,
//! so a frame from [`PreviewFrame::from_scene`] with nearest bins reproduces `burnish render`.

mod compare;
mod egui_glue;
mod environment;
mod frame;
mod objects;
mod renderer;

pub use compare::{
    CompareCallback, ComparePane, CompareRenderer, DIFFERENCE_FLOOR, compare_callback,
    difference_colour, with_compare,
};
pub use egui_glue::{
    PreviewCallback, install, install_in, paint_callback, physical_size, with_renderer,
};
pub use environment::{Environment, EnvironmentSample};
pub use frame::{
    DirectionalLight, EnvironmentLight, OrbitCamera, PreviewFrame, PreviewMode, UNOBSERVED,
};
pub use objects::{PreviewObject, material_test_object};
pub use renderer::{ENVIRONMENT_DIRECTIONS, PassCounts, PreviewRenderer, TargetLayout};

/// What went wrong in the preview.
#[derive(Debug, thiserror::Error)]
pub enum PreviewError {
    /// No GPU adapter could be found.
    #[error("no GPU adapter found: {0}")]
    NoAdapter(String),
    /// The adapter refused to create a device.
    #[error("the GPU adapter {adapter} could not create a device: {problem}")]
    Device { adapter: String, problem: String },
    /// A buffer the preview needs is larger than the device allows.
    #[error(
        "{what} needs a {bytes}-byte GPU buffer, but this device allows at most {limit} bytes \
         per storage buffer binding"
    )]
    TooLarge {
        what: String,
        bytes: u64,
        limit: u64,
    },
    /// Input the preview cannot draw.
    #[error("{0}")]
    Invalid(String),
    /// The mode needs data that was never given.
    #[error("{0}")]
    Missing(&'static str),
    /// The GPU reported an error (out of memory, or a failed pipeline or readback).
    #[error("GPU error: {0}")]
    Gpu(String),
}

/// The limits the preview asks a device for: wgpu's defaults, with the adapter's own largest
/// storage-buffer binding and buffer sizes so that a large basis fits where the hardware
/// allows. Use it in eframe's `WgpuSetupCreateNew::device_descriptor`.
pub fn required_limits(adapter: &wgpu::Adapter) -> wgpu::Limits {
    let supported = adapter.limits();
    wgpu::Limits {
        max_storage_buffer_binding_size: supported.max_storage_buffer_binding_size,
        max_buffer_size: supported.max_buffer_size,
        ..wgpu::Limits::default()
    }
}

/// A device for off-screen rendering (tests, benchmarks): no surface, no window.
///
/// Backends follow `WGPU_BACKEND` (all by default) and `WGPU_ADAPTER_NAME` picks an adapter by
/// a part of its name; otherwise hardware is preferred over a software rasteriser, and Vulkan,
/// Metal or DX12 over GL. On a machine without a GPU, Mesa's lavapipe (a software Vulkan
/// device) serves. An error says what was looked for when there is nothing.
pub fn headless_gpu() -> Result<(wgpu::Device, wgpu::Queue, wgpu::AdapterInfo), PreviewError> {
    let descriptor = wgpu::InstanceDescriptor::new_without_display_handle_from_env();
    let backends = descriptor.backends;
    let instance = wgpu::Instance::new(descriptor);
    let adapters = pollster::block_on(instance.enumerate_adapters(backends));
    let wanted = std::env::var("WGPU_ADAPTER_NAME")
        .ok()
        .map(|name| name.to_lowercase());
    let rank = |info: &wgpu::AdapterInfo| {
        let kind = match info.device_type {
            wgpu::DeviceType::DiscreteGpu => 0,
            wgpu::DeviceType::IntegratedGpu => 1,
            wgpu::DeviceType::VirtualGpu => 2,
            wgpu::DeviceType::Cpu => 3,
            wgpu::DeviceType::Other => 4,
        };
        (info.backend == wgpu::Backend::Gl, kind)
    };
    let found: Vec<String> = adapters
        .iter()
        .map(|a| {
            let info = a.get_info();
            format!("{} ({:?})", info.name, info.backend)
        })
        .collect();
    let adapter = adapters
        .into_iter()
        .filter(|a| {
            wanted
                .as_ref()
                .is_none_or(|name| a.get_info().name.to_lowercase().contains(name))
        })
        .min_by_key(|a| rank(&a.get_info()))
        .ok_or_else(|| {
            let asked = match &wanted {
                Some(name) => format!(" named like WGPU_ADAPTER_NAME={name:?}"),
                None => String::new(),
            };
            PreviewError::NoAdapter(format!(
                "no adapter{asked} among backends {backends:?} (found: {}); on Linux without a \
                 GPU, install Mesa's lavapipe (package mesa-vulkan-drivers) or set WGPU_BACKEND",
                if found.is_empty() {
                    "none".to_owned()
                } else {
                    found.join(", ")
                }
            ))
        })?;
    let info = adapter.get_info();
    let (device, queue) = pollster::block_on(adapter.request_device(&wgpu::DeviceDescriptor {
        label: Some("burnish preview"),
        required_limits: required_limits(&adapter),
        ..Default::default()
    }))
    .map_err(|e| PreviewError::Device {
        adapter: info.name.clone(),
        problem: e.to_string(),
    })?;
    Ok((device, queue, info))
}
