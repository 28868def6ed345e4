//! `burnish bench`: the analytic baseline fits its own model, the oracle is the best the basis
//! can do, and a tiny run produces every output and the JSON keys the issue asks for.

mod common;

use burnish::basis::BasisCache;
use burnish::basis::OracleProjector;
use burnish::bench::held_out::{HELD_OUT_SEED, database_materials, hand_built_materials};
use burnish::bench::live::LiveOptions;
use burnish::bench::next_view_trial::TrialOptions;
use burnish::bench::scaling::{ScalingOptions, run_scaling};
use burnish::bench::{BenchOptions, Config, Paint, VIEWS, ldr_round_trip, run_bench};
use burnish::materials::database::DatabaseSpec;
use burnish::materials::tabulate;
use burnish::metrics::table_errors;
use burnish::scene::{GBuffer, Object, render_brdf, render_table, samples_from_image};
use burnish::solver::analytic_fit::{
    Coat, Distribution, FitOptions, LambertMicrofacet, Masking, fit_lambert_microfacet,
};
use burnish::solver::{Policy, Reconstruction, Regularization, SampleKey, Solver, SparseTable};
use burnish::table::{PairIndex, SymTable, pair_multiplicity};
use common::small_basis;

/// The sparse table of `views` views of the default sphere at `resolution`, painted with
/// the renders `render` gives.
fn painted_table(
    views: usize,
    resolution: u32,
    render: impl Fn(&GBuffer) -> burnish::image_io::RgbImage,
) -> (SparseTable, Vec<burnish::solver::BinChange>) {
    let mut table = SparseTable::new(Policy::Mean);
    let mut changes = Vec::new();
    for (view, setup) in VIEWS.iter().take(views).enumerate() {
        let scene = setup.scene(resolution);
        let gbuffer = GBuffer::build(&scene, &Object::load(&scene.object_source()).unwrap());
        for s in samples_from_image(&gbuffer, &render(&gbuffer)).samples {
            let key = SampleKey {
                view: view as u32,
                pixel: s.pixel,
            };
            table
                .set_sample(key, s.light_bin, s.view_bin, s.rho, &mut changes)
                .unwrap();
        }
    }
    (table, changes)
}

#[test]
fn levenberg_marquardt_recovers_a_lambert_ggx_material_from_noise_free_samples() {
    let truth_model = LambertMicrofacet {
        albedo: [0.45, 0.2, 0.08],
        sigma: 0.0,
        f0: [0.04, 0.05, 0.06],
        distribution: Distribution::Ggx,
        alpha_x: 0.12,
        alpha_y: 0.35,
        rotation: 0.4,
        specular: 0.8,
        coat: None,
        haze: None,
        edge: None,
        masking: Masking::Smith,
    };
    let truth = tabulate(&truth_model);
    // Rendered from the table, each sample is exactly the bin-centre value: noise-free.
    let (table, _) = painted_table(2, 128, |g| render_table(g, &truth));
    let bins: Vec<(PairIndex, [f64; 3])> = table.observed().collect();
    assert!(bins.len() > 2000, "{} bins", bins.len());
    let fit = fit_lambert_microfacet(&bins, &FitOptions::default());
    println!("{fit:?}");
    let estimate = tabulate(&fit.model);
    let errors = table_errors(&truth, &estimate);
    println!("{errors:?}");
    assert!(
        errors.relative_rmse < 0.01,
        "relative RMSE {}",
        errors.relative_rmse
    );
    assert!(fit.rms_log_residual < 1e-3, "{}", fit.rms_log_residual);
    let m = fit.model;
    for c in 0..3 {
        assert!((m.albedo[c] - truth_model.albedo[c]).abs() < 0.01, "{m:?}");
        assert!((m.f0[c] - truth_model.f0[c]).abs() < 0.01, "{m:?}");
    }
    assert!((m.specular - truth_model.specular).abs() < 0.02, "{m:?}");
    // Axes turned by π (or swapped and turned by π/2) are the same lobe.
    let turn = (m.rotation - truth_model.rotation).rem_euclid(std::f64::consts::PI);
    let (ax, ay) = if (turn - std::f64::consts::FRAC_PI_2).abs() < 0.3 {
        (m.alpha_y, m.alpha_x)
    } else {
        (m.alpha_x, m.alpha_y)
    };
    assert!((ax / truth_model.alpha_x - 1.0).abs() < 0.05, "{m:?}");
    assert!((ay / truth_model.alpha_y - 1.0).abs() < 0.05, "{m:?}");
}

/// With Beckmann tried beside GGX, each shape's own material comes back in its own shape: a
/// Gaussian-tailed metal as Beckmann (GGX alone takes a narrower, taller peak for it), and a
/// GGX plastic still as GGX.
#[test]
fn the_fit_tells_a_beckmann_lobe_from_a_ggx_lobe() {
    let options = FitOptions {
        beckmann_margin: Some(1.0),
        ..FitOptions::default()
    };
    for distribution in [Distribution::Beckmann, Distribution::Ggx] {
        let truth_model = LambertMicrofacet {
            albedo: [0.02, 0.03, 0.03],
            sigma: 0.0,
            f0: [0.47, 0.49, 0.49],
            distribution,
            alpha_x: 0.29,
            alpha_y: 0.29,
            rotation: 0.0,
            specular: 1.0,
            coat: None,
            haze: None,
            edge: None,
            masking: Masking::Smith,
        };
        let truth = tabulate(&truth_model);
        let (table, _) = painted_table(2, 128, |g| render_table(g, &truth));
        let bins: Vec<(PairIndex, [f64; 3])> = table.observed().collect();
        let fit = fit_lambert_microfacet(&bins, &options);
        let m = fit.model;
        assert_eq!(m.distribution, distribution, "{m:?}");
        assert!(fit.rms_log_residual < 1e-3, "{fit:?}");
        assert!((m.alpha_x / 0.29 - 1.0).abs() < 0.05, "{m:?}");
        assert!((m.alpha_y / 0.29 - 1.0).abs() < 0.05, "{m:?}");
        let errors = table_errors(&truth, &tabulate(&m));
        assert!(errors.relative_rmse < 0.02, "{distribution:?}: {errors:?}");
    }
}

/// With a clear coat allowed, a coat over a rougher coloured lobe comes back as both lobes
/// (one lobe settles between them, about 20 times further from the table), while a one-lobe
/// material keeps one lobe: the coat must earn its place by the margin.
#[test]
fn the_fit_finds_a_clear_coat_only_where_there_is_one() {
    let options = FitOptions {
        beckmann_margin: Some(1.0),
        coat_margin: Some(1.25),
        edge_margin: None,
        ..FitOptions::default()
    };
    let coated = LambertMicrofacet {
        albedo: [0.05, 0.08, 0.2],
        sigma: 0.0,
        f0: [0.3, 0.4, 0.7],
        distribution: Distribution::Ggx,
        alpha_x: 0.3,
        alpha_y: 0.3,
        rotation: 0.0,
        specular: 0.6,
        coat: Some(Coat {
            f0: [0.04; 3],
            alpha: 0.04,
        }),
        haze: None,
        edge: None,
        masking: Masking::Smith,
    };
    let truth = tabulate(&coated);
    let (table, _) = painted_table(2, 128, |g| render_table(g, &truth));
    let bins: Vec<(PairIndex, [f64; 3])> = table.observed().collect();
    let one_lobe = fit_lambert_microfacet(&bins, &FitOptions::default());
    let fit = fit_lambert_microfacet(&bins, &options);
    let m = fit.model;
    println!("one lobe {one_lobe:?}\ntwo {fit:?}");
    let coat = m.coat.expect("a coat for a coated material");
    let alphas = [coat.alpha, (m.alpha_x * m.alpha_y).sqrt()];
    let (sharp, broad) = (alphas[0].min(alphas[1]), alphas[0].max(alphas[1]));
    assert!((coat.f0[0] / 0.04 - 1.0).abs() < 0.1, "{m:?}");
    assert!((sharp / 0.04 - 1.0).abs() < 0.1, "{m:?}");
    assert!((broad / 0.3 - 1.0).abs() < 0.1, "{m:?}");
    let errors = table_errors(&truth, &tabulate(&m));
    let one_lobe_errors = table_errors(&truth, &tabulate(&one_lobe.model));
    println!("one lobe {one_lobe_errors:?}\ntwo {errors:?}");
    assert!(errors.relative_rmse < 0.05, "{errors:?}");
    assert!(
        one_lobe_errors.relative_rmse > 4.0 * errors.relative_rmse,
        "one lobe {one_lobe_errors:?}, two {errors:?}"
    );

    let plain = LambertMicrofacet {
        coat: None,
        haze: None,
        edge: None,
        ..coated
    };
    let truth = tabulate(&plain);
    let (table, _) = painted_table(2, 128, |g| render_table(g, &truth));
    let bins: Vec<(PairIndex, [f64; 3])> = table.observed().collect();
    let fit = fit_lambert_microfacet(&bins, &options);
    assert_eq!(fit.model.coat, None, "{fit:?}");
    assert!(fit.rms_log_residual < 1e-3, "{fit:?}");
}

/// Σ_p w_p (u_pᵀx − y_p)² over the whole table: the oracle's own criterion.
fn mapped_residual(basis: &burnish::basis::Basis, truth: &SymTable, x: &[[f64; 3]]) -> f64 {
    let mut sum = 0.0;
    for (pair, value) in PairIndex::all().zip(truth.pairs()) {
        let row = basis.row(pair);
        for c in 0..3 {
            let fit: f64 = row.iter().zip(x).map(|(&u, xk)| u as f64 * xk[c]).sum();
            let y = basis.centred_observation(pair, value[c] as f64);
            sum += pair_multiplicity(pair) * (fit - y).powi(2);
        }
    }
    sum
}

#[test]
fn the_oracle_beats_or_equals_every_sparse_reconstruction() {
    let basis = small_basis(20);
    let projector = OracleProjector::new(basis.clone());
    let material = &database_materials(3)[2];
    let truth = tabulate(&*material.brdf);
    let oracle_x = projector.project(&truth);
    let oracle_table = Reconstruction::new(basis.clone(), &oracle_x).materialize();
    let oracle_residual = mapped_residual(&basis, &truth, &oracle_x);
    let oracle_errors = table_errors(&truth, &oracle_table);
    println!("{}: oracle {oracle_errors:?}", material.name);

    for views in [1, 2, 4] {
        let (_, changes) = painted_table(views, 96, |g| render_brdf(g, &*material.brdf));
        for regularization in [
            Regularization::Auto,
            Regularization::Gcv,
            Regularization::Prior { alpha: 0.01 },
        ] {
            let mut solver = Solver::new(basis.clone(), regularization);
            solver.apply_all(&changes);
            let x = solver.solve().coefficients;
            let residual = mapped_residual(&basis, &truth, &x);
            let errors = table_errors(
                &truth,
                &Reconstruction::new(basis.clone(), &x).materialize(),
            );
            println!("{views} views, {regularization:?}: {errors:?}");
            // Least squares over every pair: no coefficients can do better in its criterion…
            assert!(
                oracle_residual <= residual * (1.0 + 1e-9),
                "{views} views {regularization:?}: {oracle_residual} > {residual}"
            );
            // …and the table, clamped to the database's range, keeps the order.
            assert!(
                oracle_errors.log_rmse <= errors.log_rmse + 1e-6,
                "{views} views {regularization:?}: log RMSE {} > {}",
                oracle_errors.log_rmse,
                errors.log_rmse
            );
        }
    }
}

#[test]
fn ldr_paint_is_clipped_and_quantised_like_a_png() {
    let dir = tempfile::tempdir().unwrap();
    let image = burnish::image_io::RgbImage {
        width: 3,
        height: 1,
        pixels: vec![[0.0, 0.5, 2.0], [0.01, 0.2, 0.999], [1e-4, 0.7, 1.0]],
    };
    let path = dir.path().join("paint.png");
    burnish::scene::write_png(&path, &image).unwrap();
    let through_file = burnish::scene::read_png_linear(&path).unwrap();
    assert_eq!(ldr_round_trip(&image), through_file);
    assert_eq!(through_file.pixels[0][2], 1.0, "clipped at 1");
}

#[test]
fn held_out_materials_are_outside_the_basis_database() {
    assert_ne!(HELD_OUT_SEED, DatabaseSpec::default().seed);
    assert_ne!(
        HELD_OUT_SEED,
        burnish::basis::BasisSpec::small(20).database.seed
    );
    let hand = hand_built_materials(usize::MAX);
    assert_eq!(hand.len(), burnish::bench::held_out::HAND_BUILT);
    assert!(hand.iter().any(|m| m.lambert_ggx) && hand.iter().any(|m| !m.lambert_ggx));
    let names: std::collections::BTreeSet<String> = database_materials(20)
        .into_iter()
        .chain(hand)
        .map(|m| m.name)
        .collect();
    assert_eq!(
        names.len(),
        20 + burnish::bench::held_out::HAND_BUILT,
        "unique names"
    );
}

/// The number under `key` in a one-line JSON object.
fn json_number(json: &str, key: &str) -> Option<f64> {
    let value: serde_json::Value = serde_json::from_str(json).expect("valid JSON");
    value.get(key)?.as_f64()
}

#[test]
fn a_tiny_run_writes_every_output_and_the_required_json_keys() {
    let dir = tempfile::tempdir().unwrap();
    let cache = BasisCache::at(dir.path().join("cache"));
    let paper = Config {
        resolution: 64,
        ..Config::paper()
    };
    let options = BenchOptions {
        mode: "test",
        basis_materials: 24,
        database_materials: 1,
        hand_built: 1,
        paper,
        components: vec![20],
        regularizations: vec![Regularization::Auto],
        view_counts: vec![1, 2],
        resolutions: vec![64],
        paints: vec![Paint::Hdr, Paint::Ldr],
        policies: vec![Policy::Mean, Policy::Max],
        analytic_views: vec![1],
        fit: FitOptions {
            scout_iterations: 3,
            finalists: 1,
            max_iterations: 20,
            beckmann_margin: None,
            coat_margin: None,
            edge_margin: None,
            haze_margin: None,
            rough_margin: None,
            grazing_weight: None,
            dielectric_margin: None,
            phong_margin: None,
            gtr_margin: None,
            cavity_margin: None,
        },
        live: LiveOptions {
            dab_pixels: vec![50, 500],
            dab_components: vec![20],
            dab_repeats: 5,
            repeats: 2,
        },
        next_view: Some(TrialOptions {
            candidates: 6,
            random_picks: 2,
            resolution: 64,
        }),
        ..BenchOptions::quick(cache)
    };
    let report = run_bench(&options, &|line| eprintln!("{line}")).unwrap();
    let json = report.json();
    println!("{json}");
    assert!(!json.contains('\n') && json.starts_with('{') && json.ends_with('}'));
    for key in [
        "dab_solve_ms_p50",
        "dab_solve_ms_p95",
        "full_table_ms",
        "basis_load_ms",
        "rel_rmse_1view_k20",
        "rel_rmse_oracle_k20",
        "rel_rmse_analytic_fit",
        "rel_rmse_1view_ldr",
        "median_rel_rmse_1view_ldr",
        "rel_rmse_2view_suggested",
        "rel_rmse_2view_random",
    ] {
        let value = json_number(&json, key).unwrap_or_else(|| panic!("{key} in {json}"));
        assert!(value.is_finite() && value > 0.0, "{key} = {value}");
        // Errors of a working engine on this run sit between 0.3 and 0.8 (when written): a
        // blow-up, or a table equal to its truth, is a bug and not a figure.
        if key.contains("rel_rmse") {
            assert!((0.05..2.0).contains(&value), "{key} = {value}");
        }
    }
    let figure = |key: &str| json_number(&json, key).unwrap();
    assert!(
        figure("rel_rmse_oracle_k20") < figure("rel_rmse_1view_k20"),
        "the oracle (every bin observed) beats one view"
    );
    assert!(
        json_number(&json, "dab_solve_ms_p50").unwrap()
            <= json_number(&json, "dab_solve_ms_p95").unwrap()
    );
    let wins = json_number(&json, "next_view_suggestion_wins").unwrap();
    assert!((0.0..=1.0).contains(&wins), "{wins}");
    assert_eq!(report.next_view.len(), 2);
    for t in &report.next_view {
        assert_eq!(t.random.len(), 2);
        // A second view adds bins; it must not wreck the one-view result.
        assert!(
            t.suggested.is_finite() && t.suggested < 3.0 * t.one_view,
            "{t:?}"
        );
    }
    // Sparse: paper, the global prior, the database's mean, 2 views, LDR, max policy; plus the
    // oracle and the analytic fit.
    assert_eq!(report.aggregates.len(), 8, "{:?}", report.aggregates);
    assert_eq!(report.rows.len(), 2 * 8);
    assert_eq!(report.live.scene_skips.len(), 4);
    let stroke = &report.live.stroke;
    assert_eq!(
        stroke.pixels,
        stroke.background + stroke.shadow + stroke.grazing + stroke.unchanged + stroke.changed
    );
    assert!(stroke.background > 0 && stroke.unchanged > 0 && stroke.changed > 0);

    let out = dir.path().join("out");
    report.write_outputs(&out, "burnish bench --test").unwrap();
    let csv = std::fs::read_to_string(out.join("bench.csv")).unwrap();
    assert_eq!(csv.lines().count(), 1 + report.rows.len());
    let columns = csv.lines().next().unwrap().split(',').count();
    assert!(csv.lines().all(|l| l.split(',').count() == columns));
    assert!(
        csv.starts_with("method,")
            && csv
                .lines()
                .next()
                .unwrap()
                .ends_with(",grazing_mirror_share")
    );
    // Where each row's error lies: a share, and none where there is no error.
    for r in &report.rows {
        assert!(
            (0.0..=1.0).contains(&r.grazing_mirror_share)
                && (r.relative_rmse > 0.0 || r.grazing_mirror_share == 0.0),
            "{r:?}"
        );
    }
    let png = image::open(out.join("bench_pareto.png")).unwrap();
    assert_eq!((png.width(), png.height()), (1400, 900));
    let md = std::fs::read_to_string(out.join("BENCHMARKS.md")).unwrap();
    for needle in [
        "## Numerical stability",
        "## Next view: suggested against random",
        "burnish bench --test",
        "bench_pareto.png",
        "| grazing mirror |",
        &report.machine.cpu,
    ] {
        assert!(md.contains(needle), "{needle} in the summary");
    }
}

#[test]
fn the_scaling_sweep_measures_every_size_and_k_and_plots_them() {
    let dir = tempfile::tempdir().unwrap();
    let cache = BasisCache::at(dir.path().join("cache"));
    let base = BenchOptions {
        database_materials: 1,
        hand_built: 1,
        paper: Config {
            resolution: 64,
            ..Config::paper()
        },
        live: LiveOptions {
            dab_pixels: vec![500],
            dab_components: vec![6],
            dab_repeats: 5,
            repeats: 2,
        },
        ..BenchOptions::quick(cache)
    };
    let options = ScalingOptions {
        sizes: vec![12, 24],
        components: vec![4, 6],
        default_size: 24,
        default_components: 6,
        base,
    };
    assert_eq!(options.points(), vec![(12, 6), (24, 6), (24, 4)]);
    let report = run_scaling(&options, &|line| eprintln!("{line}")).unwrap();
    assert_eq!(report.points.len(), 3);
    assert_eq!(report.held_out, 2);
    for p in &report.points {
        for value in [
            p.oracle_mean,
            p.oracle_median,
            p.one_view_mean,
            p.one_view_median,
            p.one_view_log,
            p.dab_p95_ms,
            p.full_table_ms,
        ] {
            assert!(value.is_finite() && value > 0.0, "{p:?}");
        }
        // Relative RMSE is of order one even on a 12-material basis. (The oracle is the best
        // fit in the mapped domain, not in relative RMSE: on so small a basis it can score
        // worse than a reconstruction.)
        assert!(p.one_view_mean < 2.0 && p.oracle_mean < 3.0, "{p:?}");
        assert!(p.one_view_median <= p.one_view_mean * 2.0, "{p:?}");
        assert!(p.dab_p95_ms < 1e3 && p.full_table_ms < 1e4, "{p:?}");
        assert_eq!(p.basis, "built", "{p:?}");
    }
    let sizes: Vec<usize> = report.by_size().iter().map(|p| p.materials).collect();
    assert_eq!(sizes, [12, 24]);
    let ks: Vec<usize> = report
        .by_components()
        .iter()
        .map(|p| p.components)
        .collect();
    assert_eq!(ks, [4, 6]);

    let out = dir.path().join("out");
    report.write_outputs(&out).unwrap();
    let csv = std::fs::read_to_string(out.join("bench_scaling.csv")).unwrap();
    assert_eq!(csv.lines().count(), 1 + 3);
    let columns = csv.lines().next().unwrap().split(',').count();
    assert!(csv.lines().all(|l| l.split(',').count() == columns));
    let png = image::open(out.join("bench_scaling.png")).unwrap();
    assert_eq!((png.width(), png.height()), (1400, 700));
    let md = std::fs::read_to_string(out.join("SCALING.md")).unwrap();
    assert!(md.contains("| 12 | built") && md.contains("| 4 | "), "{md}");
}

#[test]
fn the_bench_verb_is_on_the_command_line() {
    let out = std::process::Command::new(env!("CARGO_BIN_EXE_burnish"))
        .args(["bench", "--help"])
        .output()
        .unwrap();
    assert!(out.status.success());
    let help = String::from_utf8_lossy(&out.stdout);
    for flag in ["--quick", "--json", "--out", "--scaling", "--materials"] {
        assert!(help.contains(flag), "{flag} in {help}");
    }
}
