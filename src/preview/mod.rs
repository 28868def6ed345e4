//! The wgpu preview: the object drawn with the reconstructed BRDF, evaluated on the GPU.
