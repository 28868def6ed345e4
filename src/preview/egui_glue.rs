//! The preview inside egui: a paint callback whose [`PreviewRenderer`] lives in egui-wgpu's
//! callback resources (as in egui's custom3d_wgpu demo).
//!
//! Set-up: after eframe starts, call [`install`] with the frame's `wgpu_render_state()` and the
//! `multisampling` and depth bits of eframe's `NativeOptions`, then feed the renderer with
//! [`with_renderer`] (object, basis, coefficients, sparse bins). Each frame, add
//! [`paint_callback`] to the painter over the preview's rectangle.

use super::{PreviewError, PreviewFrame, PreviewRenderer, TargetLayout};

/// One frame of the preview, drawn over its rectangle.
#[derive(Clone, Debug)]
pub struct PreviewCallback {
    pub frame: PreviewFrame,
    /// Size of the rectangle in physical pixels, as egui's viewport for it rounds.
    pub size: [u32; 2],
}

impl egui_wgpu::CallbackTrait for PreviewCallback {
    fn prepare(
        &self,
        device: &wgpu::Device,
        queue: &wgpu::Queue,
        _screen_descriptor: &egui_wgpu::ScreenDescriptor,
        _egui_encoder: &mut wgpu::CommandEncoder,
        callback_resources: &mut egui_wgpu::CallbackResources,
    ) -> Vec<wgpu::CommandBuffer> {
        if let Some(renderer) = callback_resources.get_mut::<PreviewRenderer>() {
            // The renderer submits its own commands; an error is kept for the UI to show.
            let result = renderer.prepare(device, queue, &self.frame, self.size);
            renderer.set_last_error(result.err().map(|e| e.to_string()));
        }
        Vec::new()
    }

    fn paint(
        &self,
        _info: egui::PaintCallbackInfo,
        render_pass: &mut wgpu::RenderPass<'static>,
        callback_resources: &egui_wgpu::CallbackResources,
    ) {
        if let Some(renderer) = callback_resources.get::<PreviewRenderer>()
            && renderer.last_error().is_none()
        {
            renderer.paint(render_pass);
        }
    }
}

/// The preview of `frame` over `rect`, for `ui.painter().add(...)`.
pub fn paint_callback(
    rect: egui::Rect,
    pixels_per_point: f32,
    frame: PreviewFrame,
) -> egui::PaintCallback {
    egui_wgpu::Callback::new_paint_callback(
        rect,
        PreviewCallback {
            frame,
            size: physical_size(rect, pixels_per_point),
        },
    )
}

/// The size in physical pixels of the preview drawn over `rect`: the same rounding as egui's
/// `ViewportInPixels`, so that one texel lands on one pixel.
pub fn physical_size(rect: egui::Rect, pixels_per_point: f32) -> [u32; 2] {
    let px = |v: f32| (v * pixels_per_point).round() as i64;
    let width = (px(rect.max.x) - px(rect.min.x)).max(1) as u32;
    let height = (px(rect.max.y) - px(rect.min.y)).max(1) as u32;
    [width, height]
}

/// Creates a preview renderer for passes of `layout` and stores it in `renderer`'s callback
/// resources (replacing any earlier one).
pub fn install_in(
    renderer: &mut egui_wgpu::Renderer,
    device: &wgpu::Device,
    queue: &wgpu::Queue,
    layout: TargetLayout,
) -> Result<(), PreviewError> {
    let preview = PreviewRenderer::with_layout(device, queue, layout)?;
    renderer.callback_resources.insert(preview);
    Ok(())
}

/// [`install_in`] for eframe's render state. `msaa_samples` and `depth_format` must be those
/// of egui's pass: eframe's `NativeOptions::multisampling` and
/// `egui_wgpu::depth_format_from_bits(depth_buffer, stencil_buffer)` (0 and `None` by default).
pub fn install(
    render_state: &egui_wgpu::RenderState,
    msaa_samples: u32,
    depth_format: Option<wgpu::TextureFormat>,
) -> Result<(), PreviewError> {
    let layout = TargetLayout {
        format: render_state.target_format,
        samples: msaa_samples.max(1),
        depth_format,
    };
    install_in(
        &mut render_state.renderer.write(),
        &render_state.device,
        &render_state.queue,
        layout,
    )
}

/// Runs `f` on the installed preview renderer; `None` if [`install`] was not called.
pub fn with_renderer<R>(
    render_state: &egui_wgpu::RenderState,
    f: impl FnOnce(&mut PreviewRenderer) -> R,
) -> Option<R> {
    render_state
        .renderer
        .write()
        .callback_resources
        .get_mut::<PreviewRenderer>()
        .map(f)
}
