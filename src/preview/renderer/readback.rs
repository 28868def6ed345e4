//! Reading the GPU's results back: rendered images, a picked pixel, the evaluated table.

use super::{Evaluation, PreviewRenderer, allocate};
use crate::image_io::RgbImage;
use crate::preview::PreviewError;
use crate::preview::frame::PreviewFrame;
use crate::table::{PAIRS, SymTable};

impl PreviewRenderer {
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
