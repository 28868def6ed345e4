//! Burnish: paint how a material looks on an object of known shape and light,
//! and get back a full tabulated BRDF (after Davis et al. 2019 and Nielsen et al. 2015).
//!
//! Data flows one way: scene → guide buffer → canvas → changed pixels → worker →
//! snapshot → preview. This library is the engine; it knows nothing of the UI.

// Colour channels and matrix rows index several parallel arrays at once; an index reads
// clearer there than zipped iterators.
#![allow(clippy::needless_range_loop)]

#[cfg(feature = "app")]
pub mod app;
pub mod basis;
pub mod bench;
pub mod bounded_read;
pub mod brdf;
pub mod cli;
pub mod document;
pub mod error;
pub mod export;
pub mod fs_atomic;
pub mod image_io;
pub mod inspect;
pub mod materials;
pub mod metrics;
pub mod next_view;
pub mod paint;
#[cfg(feature = "app")]
pub mod preview;
pub mod scene;
pub mod session;
pub mod solver;
pub mod table;
pub mod worker;

pub use error::{Error, Result};
