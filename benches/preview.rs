//! Preview frame times on the headless adapter (Mesa lavapipe where there is no GPU): one frame
//! is `prepare` (uniforms, passes, submit) and waiting for the GPU to finish, without readback.
//! "geometry" cases turn the camera every frame, so that the geometry raster and per-pixel
//! set-up run each time; "snapshot" cases set new coefficients (K = 20) every frame, which is
//! what painting costs: the evaluation of the pairs the view reads and one gather pass. Also
//! the evaluation of all 1,313,010 pairs, and sparse-bin updates.

mod common;

use burnish::basis::{BasisSpec, build_basis};
use burnish::materials::models::{Distribution, Fresnel, Microfacet};
use burnish::materials::tabulate;
use burnish::preview::{
    EnvironmentLight, PreviewFrame, PreviewMode, PreviewRenderer, headless_gpu,
    material_test_object,
};
use burnish::scene::{BuiltinShape, Object};
use burnish::solver::{BinChange, EXACT};
use burnish::table::{PAIRS, PairIndex};
use criterion::{Criterion, criterion_group, criterion_main};
use std::time::Duration;

fn previews(c: &mut Criterion) {
    let (device, queue, info) = headless_gpu().expect("a GPU adapter (lavapipe will do)");
    eprintln!("adapter: {} ({:?})", info.name, info.backend);
    let mut renderer =
        PreviewRenderer::new(&device, &queue, wgpu::TextureFormat::Rgba8Unorm).unwrap();
    let glossy = Microfacet::isotropic(
        Distribution::Ggx,
        0.25,
        Fresnel::Schlick {
            f0: [0.9, 0.7, 0.5],
        },
    );
    renderer.set_table(&tabulate(&glossy)).unwrap();
    // In test mode a tiny basis (K = 20 all the same): only the check is quick.
    let basis = if common::test_mode() {
        common::check_basis(20)
    } else {
        build_basis(&BasisSpec::small(20), &|_| {})
    };
    renderer.set_basis(&basis).unwrap();
    let coefficients: Vec<Vec<[f64; 3]>> = (0..2)
        .map(|seed| {
            basis
                .variances()
                .iter()
                .enumerate()
                .map(|(k, v)| {
                    let s = v.sqrt() * if (k + seed) % 2 == 0 { 0.5 } else { -0.5 };
                    [s, 0.8 * s, 0.6 * s]
                })
                .collect()
        })
        .collect();
    let sphere = Object::builtin(BuiltinShape::Sphere);
    let bowl = Object::from_obj(concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/assets/meshes/bowl.obj"
    ))
    .unwrap();
    let torus = Object::builtin(BuiltinShape::Torus);

    let material_test = material_test_object();

    let wait = |device: &wgpu::Device| {
        device
            .poll(wgpu::PollType::wait_indefinitely())
            .expect("poll");
    };
    let mut group = c.benchmark_group("preview");
    group
        .sample_size(10)
        .warm_up_time(Duration::from_secs(1))
        .measurement_time(Duration::from_secs(4));
    // `cargo test` passes no `--bench` and criterion then runs each benchmark once to check
    // it works: one size is enough there.
    let sizes: &[u32] = if common::test_mode() {
        &[256]
    } else {
        &[512, 1024]
    };
    for &size in sizes {
        let table = |interpolate| PreviewFrame {
            mode: PreviewMode::Table,
            interpolate,
            ..PreviewFrame::default()
        };
        let lights = PreviewFrame {
            second_light: Some(burnish::preview::DirectionalLight {
                elevation_deg: 20.0,
                azimuth_deg: -60.0,
                intensity: 0.5,
            }),
            environment: Some(EnvironmentLight::default()),
            ..table(true)
        };
        let cases: [(&str, &Object, PreviewFrame); 6] = [
            ("sphere table nearest", &sphere, table(false)),
            ("sphere table interpolated", &sphere, table(true)),
            (
                "sphere interpolated, fill light and 256-direction environment",
                &sphere,
                lights,
            ),
            ("bowl mesh interpolated, shadows", &bowl, table(true)),
            (
                "torus mesh (37k triangles) interpolated, shadows",
                &torus,
                table(true),
            ),
            (
                "material-test mesh interpolated, shadows",
                &material_test,
                table(true),
            ),
        ];
        for (name, object, frame) in cases {
            renderer.set_object(object).unwrap();
            let mut frame = frame;
            group.bench_function(format!("geometry: {name} {size}²"), |b| {
                b.iter(|| {
                    // A new camera every frame: everything but the shadow map is redone.
                    frame.camera.yaw_deg = if frame.camera.yaw_deg == 0.0 {
                        1.0
                    } else {
                        0.0
                    };
                    renderer
                        .prepare(&device, &queue, &frame, [size, size])
                        .unwrap();
                    wait(&device);
                })
            });
        }
        for (name, object, environment, draft) in [
            ("sphere", &sphere, false, false),
            ("sphere, draft", &sphere, false, true),
            ("torus mesh", &torus, false, false),
            ("sphere with the environment", &sphere, true, false),
            ("sphere with the environment, draft", &sphere, true, true),
        ] {
            renderer.set_object(object).unwrap();
            let frame = PreviewFrame {
                mode: PreviewMode::Reconstruction,
                interpolate: true,
                environment: environment.then(EnvironmentLight::default),
                draft,
                ..PreviewFrame::default()
            };
            let mut which = 0;
            group.bench_function(
                format!("snapshot: {name}, reconstruction K=20 interpolated {size}²"),
                |b| {
                    b.iter(|| {
                        which ^= 1;
                        renderer.set_coefficients(&coefficients[which]).unwrap();
                        renderer
                            .prepare(&device, &queue, &frame, [size, size])
                            .unwrap();
                        wait(&device);
                    })
                },
            );
        }
        renderer.set_object(&sphere).unwrap();
        let frame = PreviewFrame {
            mode: PreviewMode::Reconstruction,
            interpolate: true,
            ..PreviewFrame::default()
        };
        group.bench_function(format!("unchanged frame {size}²"), |b| {
            b.iter(|| {
                renderer
                    .prepare(&device, &queue, &frame, [size, size])
                    .unwrap();
                wait(&device);
            })
        });
    }
    // The evaluation of every pair (as for an export), read back.
    let mut which = 0;
    group.bench_function(
        "new coefficients: K=20 evaluation of all pairs, with readback",
        |b| {
            b.iter(|| {
                which ^= 1;
                renderer.set_coefficients(&coefficients[which]).unwrap();
                renderer.reconstruction_table(&device, &queue).unwrap();
            })
        },
    );
    // A dab's worth of sparse bins: 2,000 scattered pairs.
    let changes: Vec<BinChange> = (0..2000)
        .map(|i| {
            let pair = PairIndex::from_index((i * 656_503) % PAIRS);
            BinChange::observed(pair, [0.2, 0.3, 0.4], EXACT)
        })
        .collect();
    group.bench_function("update_sparse: 2,000 scattered pairs", |b| {
        b.iter(|| {
            renderer.update_sparse(&changes).unwrap();
            queue.submit([]);
            wait(&device);
        })
    });
    group.finish();
}

criterion_group!(benches, previews);
criterion_main!(benches);
