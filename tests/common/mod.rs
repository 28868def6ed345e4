//! Shared helpers for the engine's integration tests.
#![allow(dead_code)]

use burnish::basis::{Basis, BasisSpec, build_basis};
use burnish::materials::Brdf;
use burnish::solver::SampleKey;
use burnish::table::{DirIndex, direction_index};
use glam::DVec3;
use std::collections::HashMap;
use std::sync::{Arc, Mutex, OnceLock};

/// The small test database's basis with `k` components, built once per test binary.
pub fn small_basis(k: usize) -> Arc<Basis> {
    static CACHE: OnceLock<Mutex<HashMap<usize, Arc<Basis>>>> = OnceLock::new();
    let cache = CACHE.get_or_init(Default::default);
    let mut guard = cache.lock().unwrap();
    guard
        .entry(k)
        .or_insert_with(|| Arc::new(build_basis(&BasisSpec::small(k), &|_| {})))
        .clone()
}

/// One painted pixel: its key, light and view bins, and ρ.
pub type PixelSample = (SampleKey, DirIndex, DirIndex, [f64; 3]);

/// What a perfect painter gives on an orthographic unit sphere seen from +z, lit from
/// (elevation, azimuth) as SCENE.md defines them, tangent reference +x: ρ at each pixel's exact
/// local directions, binned. Pixels with cos θ_l or cos θ_v under 0.1 are skipped.
pub fn sphere_view_samples(
    brdf: &dyn Brdf,
    view: u32,
    elevation_deg: f64,
    azimuth_deg: f64,
    resolution: usize,
) -> Vec<PixelSample> {
    let (el, az) = (elevation_deg.to_radians(), azimuth_deg.to_radians());
    let light = DVec3::new(el.cos() * az.sin(), el.sin(), el.cos() * az.cos());
    let view_dir = DVec3::Z;
    let mut out = Vec::new();
    for py in 0..resolution {
        for px in 0..resolution {
            let x = (px as f64 + 0.5) / resolution as f64 * 2.0 - 1.0;
            let y = 1.0 - (py as f64 + 0.5) / resolution as f64 * 2.0;
            let r2 = x * x + y * y;
            if r2 >= 1.0 {
                continue;
            }
            let n = DVec3::new(x, y, (1.0 - r2).sqrt());
            let r = DVec3::X;
            let t = (r - r.dot(n) * n).normalize();
            let b = n.cross(t);
            let local = |w: DVec3| DVec3::new(w.dot(t), w.dot(b), w.dot(n));
            let (l, v) = (local(light), local(view_dir));
            if l.z < 0.1 || v.z < 0.1 {
                continue;
            }
            let (Some(d_l), Some(d_v)) = (direction_index(l), direction_index(v)) else {
                continue;
            };
            let key = SampleKey {
                view,
                pixel: (py * resolution + px) as u32,
            };
            out.push((key, d_l, d_v, brdf.eval(l, v)));
        }
    }
    out
}
