//! Burnish: paint how a material looks on an object of known shape and light,
//! and get back a full tabulated BRDF (after Davis et al. 2019 and Nielsen et al. 2015).
//!
//! Data flows one way: scene → guide buffer → canvas → changed pixels → worker →
//! snapshot → preview. This library is the engine; it knows nothing of the UI.

pub mod error;
pub mod fs_atomic;
pub mod image_io;
pub mod materials;
pub mod scene;
pub mod table;

pub use error::{Error, Result};
