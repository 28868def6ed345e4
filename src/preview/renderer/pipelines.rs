//! The preview's shaders, bind group layouts and pipelines, made once per renderer.

use super::{DEPTH_FORMAT, RADIANCE_FORMAT, TargetLayout};
use crate::preview::PreviewError;

/// Every pipeline the renderer runs, and the bind group layouts they share.
pub(super) struct Pipelines {
    pub(super) layouts: BindGroupLayouts,
    /// Geometry raster of the analytic sphere, traced per pixel.
    pub(super) sphere: wgpu::RenderPipeline,
    /// Geometry raster of a mesh.
    pub(super) mesh: wgpu::RenderPipeline,
    pub(super) shadow: wgpu::RenderPipeline,
    /// Per-pixel set-up of the geometry records.
    pub(super) setup: wgpu::ComputePipeline,
    pub(super) gather: wgpu::ComputePipeline,
    /// The gather at a quarter of the pixels, for dragging.
    pub(super) draft: wgpu::ComputePipeline,
    /// The reconstruction of every pair.
    pub(super) reconstruct_all: wgpu::ComputePipeline,
    /// The reconstruction of the pairs the view reads.
    pub(super) reconstruct_listed: wgpu::ComputePipeline,
    /// Lists the marked pairs.
    pub(super) compact: wgpu::ComputePipeline,
    /// Sizes the listed reconstruction's indirect dispatch.
    pub(super) size_dispatch: wgpu::ComputePipeline,
    pub(super) present: wgpu::RenderPipeline,
}

/// What each kind of pass binds.
pub(super) struct BindGroupLayouts {
    /// The geometry raster and shadow passes: the frame's uniforms.
    pub(super) raster: wgpu::BindGroupLayout,
    /// The set-up and gather passes.
    pub(super) shade: wgpu::BindGroupLayout,
    pub(super) reconstruction: wgpu::BindGroupLayout,
    pub(super) view_pairs: wgpu::BindGroupLayout,
    pub(super) present: wgpu::BindGroupLayout,
}

/// The WGSL modules in `shaders/`.
struct ShaderModules {
    scene: wgpu::ShaderModule,
    shade: wgpu::ShaderModule,
    reconstruction: wgpu::ShaderModule,
    view_pairs: wgpu::ShaderModule,
    present: wgpu::ShaderModule,
}

impl Pipelines {
    /// Compiles the shaders and makes the pipelines for passes of `layout`; a validation
    /// error (a shader or a layout the device refuses) is returned, not raised.
    pub(super) fn new(device: &wgpu::Device, layout: TargetLayout) -> Result<Self, PreviewError> {
        let validation = device.push_error_scope(wgpu::ErrorFilter::Validation);
        let modules = ShaderModules::new(device);
        let layouts = BindGroupLayouts::new(device);
        let pipelines = Self::create(device, layout, &modules, layouts);
        if let Some(error) = pollster::block_on(validation.pop()) {
            return Err(PreviewError::Gpu(format!(
                "the preview's pipelines could not be created for {layout:?}: {error}"
            )));
        }
        Ok(pipelines)
    }

    fn create(
        device: &wgpu::Device,
        layout: TargetLayout,
        modules: &ShaderModules,
        layouts: BindGroupLayouts,
    ) -> Self {
        let pipeline_layout = |layout: &wgpu::BindGroupLayout, label: &str| {
            device.create_pipeline_layout(&wgpu::PipelineLayoutDescriptor {
                label: Some(label),
                bind_group_layouts: &[Some(layout)],
                immediate_size: 0,
            })
        };
        let scene_pipeline_layout = pipeline_layout(&layouts.raster, "preview geometry");
        let shade_pipeline_layout = pipeline_layout(&layouts.shade, "preview shading");
        let compute_pipeline_layout =
            pipeline_layout(&layouts.reconstruction, "preview reconstruction");
        let pairs_pipeline_layout = pipeline_layout(&layouts.view_pairs, "preview view pairs");
        let present_pipeline_layout = pipeline_layout(&layouts.present, "preview present");

        let (sphere, mesh, shadow) =
            raster_pipelines(device, &scene_pipeline_layout, &modules.scene);
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
        let reconstruct_listed = compute_pipeline(
            "preview reconstruction of listed pairs",
            &compute_pipeline_layout,
            &modules.reconstruction,
            "reconstruct_listed",
        );
        let compact = compute_pipeline(
            "preview view pairs",
            &pairs_pipeline_layout,
            &modules.view_pairs,
            "compact",
        );
        let size_dispatch = compute_pipeline(
            "preview view pairs dispatch",
            &pairs_pipeline_layout,
            &modules.view_pairs,
            "size_dispatch",
        );
        let setup = compute_pipeline(
            "preview set-up",
            &shade_pipeline_layout,
            &modules.shade,
            "setup",
        );
        let gather = compute_pipeline(
            "preview gather",
            &shade_pipeline_layout,
            &modules.shade,
            "gather",
        );
        let draft = compute_pipeline(
            "preview draft gather",
            &shade_pipeline_layout,
            &modules.shade,
            "gather_draft",
        );
        let reconstruct_all = compute_pipeline(
            "preview reconstruction",
            &compute_pipeline_layout,
            &modules.reconstruction,
            "reconstruct",
        );
        let present = present_pipeline(device, layout, &present_pipeline_layout, &modules.present);
        Self {
            layouts,
            sphere,
            mesh,
            shadow,
            setup,
            gather,
            draft,
            reconstruct_all,
            reconstruct_listed,
            compact,
            size_dispatch,
            present,
        }
    }
}

impl ShaderModules {
    fn new(device: &wgpu::Device) -> Self {
        let scene = device.create_shader_module(wgpu::ShaderModuleDescriptor {
            label: Some("preview geometry"),
            source: wgpu::ShaderSource::Wgsl(
                concat!(
                    include_str!("../../../shaders/frame.wgsl"),
                    include_str!("../../../shaders/preview.wgsl")
                )
                .into(),
            ),
        });
        let shade = device.create_shader_module(wgpu::ShaderModuleDescriptor {
            label: Some("preview shading"),
            source: wgpu::ShaderSource::Wgsl(
                concat!(
                    include_str!("../../../shaders/frame.wgsl"),
                    include_str!("../../../shaders/shade.wgsl")
                )
                .into(),
            ),
        });
        let reconstruction = device.create_shader_module(wgpu::ShaderModuleDescriptor {
            label: Some("preview reconstruction"),
            source: wgpu::ShaderSource::Wgsl(
                include_str!("../../../shaders/reconstruct.wgsl").into(),
            ),
        });
        let view_pairs = device.create_shader_module(wgpu::ShaderModuleDescriptor {
            label: Some("preview view pairs"),
            source: wgpu::ShaderSource::Wgsl(
                include_str!("../../../shaders/view_pairs.wgsl").into(),
            ),
        });
        let present = device.create_shader_module(wgpu::ShaderModuleDescriptor {
            label: Some("preview present"),
            source: wgpu::ShaderSource::Wgsl(include_str!("../../../shaders/present.wgsl").into()),
        });
        Self {
            scene,
            shade,
            reconstruction,
            view_pairs,
            present,
        }
    }
}

impl BindGroupLayouts {
    fn new(device: &wgpu::Device) -> Self {
        let fragment = wgpu::ShaderStages::FRAGMENT;
        let compute = wgpu::ShaderStages::COMPUTE;
        let raster = device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
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
        let shade = device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
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
        let reconstruction = device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
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
        let view_pairs = device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
            label: Some("preview view pairs"),
            entries: &[
                uniform_entry(0, compute),
                storage_entry(1, compute, true),
                storage_entry(2, compute, false),
                storage_entry(3, compute, false),
            ],
        });
        let present = device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
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
        Self {
            raster,
            shade,
            reconstruction,
            view_pairs,
            present,
        }
    }
}

/// The geometry raster pipelines (sphere and mesh) and the shadow pipeline.
fn raster_pipelines(
    device: &wgpu::Device,
    scene_pipeline_layout: &wgpu::PipelineLayout,
    scene_module: &wgpu::ShaderModule,
) -> (
    wgpu::RenderPipeline,
    wgpu::RenderPipeline,
    wgpu::RenderPipeline,
) {
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
    let scene_pipeline = |label: &str,
                          vertex_entry: &str,
                          fragment_entry: &str,
                          buffers: &[Option<wgpu::VertexBufferLayout>]| {
        device.create_render_pipeline(&wgpu::RenderPipelineDescriptor {
            label: Some(label),
            layout: Some(scene_pipeline_layout),
            vertex: wgpu::VertexState {
                module: scene_module,
                entry_point: Some(vertex_entry),
                compilation_options: Default::default(),
                buffers,
            },
            primitive,
            depth_stencil: depth_state(wgpu::CompareFunction::Less),
            multisample: wgpu::MultisampleState::default(),
            fragment: Some(wgpu::FragmentState {
                module: scene_module,
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
        layout: Some(scene_pipeline_layout),
        vertex: wgpu::VertexState {
            module: scene_module,
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
    (sphere_pipeline, mesh_pipeline, shadow_pipeline)
}

/// The pipeline that copies the radiance texture into the caller's pass of `layout`.
fn present_pipeline(
    device: &wgpu::Device,
    layout: TargetLayout,
    present_pipeline_layout: &wgpu::PipelineLayout,
    present_module: &wgpu::ShaderModule,
) -> wgpu::RenderPipeline {
    device.create_render_pipeline(&wgpu::RenderPipelineDescriptor {
        label: Some("preview present"),
        layout: Some(present_pipeline_layout),
        vertex: wgpu::VertexState {
            module: present_module,
            entry_point: Some("vs_present"),
            compilation_options: Default::default(),
            buffers: &[],
        },
        primitive: wgpu::PrimitiveState::default(),
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
            module: present_module,
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
    })
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
