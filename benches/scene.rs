//! Scene figures (shadows on, the default): geometry buffers of a 1024² sphere and of a
//! ~100k-triangle OBJ (and loading it with its BVH), then on the OBJ's 1024² buffer: painted
//! image to samples, table render and guide.

use burnish::scene::{
    BuiltinShape, GBuffer, Mesh, Object, Scene, guide_image, render_table, samples_from_image,
};
use burnish::table::SymTable;
use criterion::{Criterion, criterion_group, criterion_main};
use glam::DVec3;
use std::f64::consts::{PI, TAU};
use std::hint::black_box;
use std::time::Duration;

/// A lumpy UV sphere: `rings × segments` quads, about 100k triangles at 225 × 224.
fn lumpy_sphere(rings: usize, segments: usize) -> Mesh {
    let radius = |u: DVec3| {
        1.0 + 0.15 * (5.0 * u.x).sin() * (4.0 * u.y + 1.0).cos() + 0.1 * (7.0 * u.z).sin()
    };
    let mut positions = vec![DVec3::Y * radius(DVec3::Y)];
    for i in 1..rings {
        let theta = PI * i as f64 / rings as f64;
        for j in 0..segments {
            let phi = TAU * j as f64 / segments as f64;
            let u = DVec3::new(
                theta.sin() * phi.cos(),
                theta.cos(),
                -theta.sin() * phi.sin(),
            );
            positions.push(u * radius(u));
        }
    }
    positions.push(-DVec3::Y * radius(-DVec3::Y));
    let bottom = positions.len() as u32 - 1;
    let ring = |i: usize, j: usize| (1 + (i - 1) * segments + j % segments) as u32;
    let mut triangles = Vec::new();
    for j in 0..segments {
        triangles.push([0, ring(1, j), ring(1, j + 1)]);
        triangles.push([bottom, ring(rings - 1, j + 1), ring(rings - 1, j)]);
    }
    for i in 1..rings - 1 {
        for j in 0..segments {
            triangles.push([ring(i, j), ring(i + 1, j), ring(i + 1, j + 1)]);
            triangles.push([ring(i, j), ring(i + 1, j + 1), ring(i, j + 1)]);
        }
    }
    Mesh::new(positions, None, triangles).expect("a valid mesh")
}

fn scene_benches(c: &mut Criterion) {
    let scene = Scene {
        resolution: 1024,
        ..Scene::default()
    };
    let sphere = Object::builtin(BuiltinShape::Sphere);
    c.bench_function("gbuffer_1024_sphere", |b| {
        b.iter(|| black_box(GBuffer::build(&scene, &sphere)))
    });

    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("lumpy.obj");
    lumpy_sphere(225, 224).write_obj(&path, false).unwrap();
    c.bench_function("obj_load_and_bvh_100k_triangles", |b| {
        b.iter(|| black_box(Object::from_obj(&path).unwrap()))
    });
    let object = Object::from_obj(&path).unwrap();
    c.bench_function("gbuffer_1024_obj_100k_triangles", |b| {
        b.iter(|| black_box(GBuffer::build(&scene, &object)))
    });

    // As the old timings did: the remaining figures on the OBJ's geometry buffer.
    let gbuffer = GBuffer::build(&scene, &object);
    let table = SymTable::filled([0.2; 3]);
    let painting = render_table(&gbuffer, &table);
    c.bench_function("samples_from_image_1024", |b| {
        b.iter(|| black_box(samples_from_image(&gbuffer, &painting)))
    });
    c.bench_function("render_table_1024", |b| {
        b.iter(|| black_box(render_table(&gbuffer, &table)))
    });
    c.bench_function("guide_image_1024", |b| {
        b.iter(|| black_box(guide_image(&gbuffer)))
    });
}

criterion_group! {
    name = benches;
    config = Criterion::default().sample_size(10).measurement_time(Duration::from_secs(5));
    targets = scene_benches
}
criterion_main!(benches);
