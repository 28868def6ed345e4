//! reconstruct(render(T)) for materials the basis has never seen: the whole pipeline through
//! real files, scored with `burnish eval`'s metrics.

mod common;

use burnish::bench::held_out::{HAND_BUILT, hand_built_materials};
use burnish::materials::database::material;
use burnish::materials::tabulate;
use burnish::metrics::{Evaluation, evaluate};
use burnish::scene::{
    GBuffer, LightSettings, Object, Scene, render_table, samples_from_file, write_image,
};
use burnish::solver::{PriorMean, Regularization, Solver, SparseTable};
use burnish::table::SymTable;
use common::small_basis;

const HELD_OUT_SEED: u64 = 0x0bad_cafe;
const MATERIALS: usize = 6;
/// The lights (elevation, azimuth) of the three views; the first alone is the one-view case.
const LIGHTS: [(f64, f64); 3] = [(45.0, 30.0), (20.0, -60.0), (70.0, 150.0)];

/// Renders `truth` as a perfect painter would for each light, writes it as an EXR painting,
/// reads it back and reconstructs from all of them.
fn reconstruct_from_renders(
    truth: &SymTable,
    lights: &[(f64, f64)],
    dir: &std::path::Path,
) -> SymTable {
    reconstruct_from_paintings(truth, lights, dir, "exr")
}

/// [`reconstruct_from_renders`] through painting files of type `extension` (`png`: 8-bit,
/// clipped at 1, read back as bounds where clipped).
fn reconstruct_from_paintings(
    truth: &SymTable,
    lights: &[(f64, f64)],
    dir: &std::path::Path,
    extension: &str,
) -> SymTable {
    reconstruct_with_mean(truth, lights, dir, extension, PriorMean::FITTED)
}

fn reconstruct_with_mean(
    truth: &SymTable,
    lights: &[(f64, f64)],
    dir: &std::path::Path,
    extension: &str,
    prior_mean: PriorMean,
) -> SymTable {
    let basis = small_basis(20);
    let mut table = SparseTable::default();
    let mut changes = Vec::new();
    for (view, &(elevation_deg, azimuth_deg)) in lights.iter().enumerate() {
        let scene = Scene {
            resolution: 128,
            light: LightSettings {
                elevation_deg,
                azimuth_deg,
            },
            ..Scene::default()
        };
        let gbuffer = GBuffer::build(&scene, &Object::load(&scene.object_source()).unwrap());
        let painting = dir.join(format!("view{view}.{extension}"));
        write_image(&painting, &render_table(&gbuffer, truth)).unwrap();
        let set = samples_from_file(&gbuffer, &painting).unwrap();
        assert!(
            set.counts.used > 2000 && set.counts.invalid == 0,
            "{:?}",
            set.counts
        );
        set.insert_into(view as u32, &mut table, &mut changes)
            .unwrap();
    }
    let mut solver = Solver::new(basis.clone(), Regularization::Auto);
    solver.set_mean_kind(prior_mean);
    solver.apply_all(&changes);
    solver.refit_prior_mean();
    solver.solve().reconstruction(basis).materialize()
}

fn mean(evaluations: &[Evaluation], field: impl Fn(&Evaluation) -> f64) -> f64 {
    evaluations.iter().map(field).sum::<f64>() / evaluations.len() as f64
}

#[test]
fn one_view_is_within_the_stated_error_and_three_views_beat_one() {
    let dir = tempfile::tempdir().unwrap();
    let (mut one, mut three) = (Vec::new(), Vec::new());
    for i in 0..MATERIALS {
        let truth = tabulate(&*material(HELD_OUT_SEED, i).brdf);
        one.push(evaluate(
            &truth,
            &reconstruct_from_renders(&truth, &LIGHTS[..1], dir.path()),
        ));
        three.push(evaluate(
            &truth,
            &reconstruct_from_renders(&truth, &LIGHTS, dir.path()),
        ));
        println!(
            "{:<60} relative RMSE {:.4} → {:.4}",
            material(HELD_OUT_SEED, i).label,
            one[i].relative_rmse,
            three[i].relative_rmse
        );
    }
    let report = |name: &str, e: &[Evaluation]| {
        println!(
            "{name}: relative RMSE {:.3}, log RMSE {:.3}, median PSNR {:.1} dB",
            mean(e, |e| e.relative_rmse),
            mean(e, |e| e.log_rmse),
            mean(e, |e| e.median_psnr_db)
        );
    };
    report("one view", &one);
    report("three views", &three);
    // Stated bounds for the 48-material test basis (K = 20) over six held-out materials,
    // about 5% (1 dB) from what is measured, so that a regression of that size fails: one
    // view median relative RMSE 0.082, mean log RMSE 0.059, median PSNR 73.7 dB; three views
    // mean relative RMSE 0.183, log RMSE 0.047, 73.8 dB. Before a fit that explains the paint
    // three times as closely as the database's mean was taken whatever the evidence
    // (`+closer:3`), the rough plastic and the Lambert surface stayed on the mean from one
    // view: one view 0.136, 0.110, 50.7 dB, three views 0.187, 0.047, 69.3 dB (with the GGX
    // reference alone: one view log RMSE 0.120, 49.5 dB, three views 0.310, 0.073, 68.3 dB;
    // on the database's mean: one view 0.645 mean relative, 0.214 log, 39.3 dB; three views
    // 0.433, 0.195, 43.0 dB).
    //
    // One view's mean relative RMSE (0.486) is not bounded: one material owns it. A Phong
    // n = 1280 highlight without Fresnel, seen under one light, is fitted by a lobe whose
    // Fresnel and 1/(4 cos θ_l cos θ_v) rise toward grazing where no bin was painted, and the
    // grazing mirror entries come out too bright (relative RMSE 2.0 with the Beckmann lobe,
    // 9.5 with GGX alone; log RMSE stays low). A second and third light fix it (0.47); until
    // the fit can tell, it is bounded here so that it cannot get worse unseen.
    let median_one = median(&one, |e| e.relative_rmse);
    assert!(
        median_one < 0.086,
        "one view: median relative RMSE {median_one}"
    );
    assert!(
        one.iter().all(|e| e.relative_rmse < 2.2),
        "one view: a material's relative RMSE beyond the Phong highlight's 2.0"
    );
    assert!(mean(&one, |e| e.log_rmse) < 0.062, "one view: log RMSE");
    assert!(
        mean(&one, |e| e.median_psnr_db) > 72.7,
        "one view: median PSNR"
    );
    assert!(
        mean(&three, |e| e.relative_rmse) < 0.192,
        "three views: relative RMSE"
    );
    assert!(
        mean(&three, |e| e.log_rmse) < 0.050,
        "three views: log RMSE"
    );
    assert!(
        mean(&three, |e| e.median_psnr_db) > 72.8,
        "three views: median PSNR"
    );
    assert!(
        mean(&three, |e| e.relative_rmse) < mean(&one, |e| e.relative_rmse),
        "three views beat one (relative RMSE)"
    );
    assert!(
        mean(&three, |e| e.log_rmse) < mean(&one, |e| e.log_rmse),
        "three views beat one (log RMSE)"
    );
    assert!(
        mean(&three, |e| e.median_psnr_db) > mean(&one, |e| e.median_psnr_db),
        "three views beat one (PSNR)"
    );
}

/// 8-bit paint is censored data: a clipped highlight only says "at least this bright". On
/// the six held-out materials painted once as PNG (clipped at 1, quantised) and once as EXR,
/// the 8-bit reconstruction must stay close to the HDR one, material by material.
///
/// Close to what HDR paint tells under Schlick's Fresnel: a metal's exact Fresnel (the fitted
/// reference's edge tint) is told by the height of its peak against its shoulders, which an
/// HDR view holds and a clipped 8-bit view does not, so HDR paint of a metal can be exact
/// where one 8-bit view stays where Schlick's reference leaves it. The edge tint must not
/// make 8-bit paint worse than Schlick's reference does. Likewise the prior over a lobe's
/// unseen specular weight (`+grazing:0.98`) is not what the paint tells: it moves the weight
/// only as far as the paint could not show the change, which HDR paint and 8-bit rounding
/// judge differently, so each material's 8-bit view is held to the worse of what HDR paint
/// tells with and without it.
#[test]
fn eight_bit_paint_is_nearly_as_good_as_hdr() {
    // What 8-bit paint may cost where HDR paint is exact, as a ratio cannot say: from one
    // HDR view the rough plastic's fit is exact, from the 8-bit view (rounded to 1/255) it
    // comes out at 0.0077, log 0.076 (both 0.112, log 0.153, while the evidence alone chose
    // the reference).
    const QUANTISATION_RELATIVE: f64 = 0.01;
    const QUANTISATION_LOG: f64 = 0.1;
    let dir = tempfile::tempdir().unwrap();
    let mut schlick = PriorMean::FITTED;
    if let PriorMean::Fitted { edge_margin, .. } = &mut schlick {
        *edge_margin = None;
    }
    let mut unsplit = PriorMean::FITTED;
    if let PriorMean::Fitted { grazing_weight, .. } = &mut unsplit {
        *grazing_weight = None;
    }
    let (mut hdr, mut ldr, mut hdr_schlick, mut ldr_schlick) =
        (Vec::new(), Vec::new(), Vec::new(), Vec::new());
    let mut hdr_unsplit = Vec::new();
    for i in 0..MATERIALS {
        let truth = tabulate(&*material(HELD_OUT_SEED, i).brdf);
        let score = |extension, mean| {
            evaluate(
                &truth,
                &reconstruct_with_mean(&truth, &LIGHTS[..1], dir.path(), extension, mean),
            )
        };
        hdr.push(score("exr", PriorMean::FITTED));
        ldr.push(score("png", PriorMean::FITTED));
        hdr_schlick.push(score("exr", schlick));
        ldr_schlick.push(score("png", schlick));
        hdr_unsplit.push(score("exr", unsplit));
        println!(
            "{:<60} relative RMSE HDR {:.4} 8-bit {:.4} (Schlick's {:.4} {:.4}, HDR without the grazing weight {:.4}), log RMSE {:.4} {:.4} ({:.4} {:.4})",
            material(HELD_OUT_SEED, i).label,
            hdr[i].relative_rmse,
            ldr[i].relative_rmse,
            hdr_schlick[i].relative_rmse,
            ldr_schlick[i].relative_rmse,
            hdr_unsplit[i].relative_rmse,
            hdr[i].log_rmse,
            ldr[i].log_rmse,
            hdr_schlick[i].log_rmse,
            ldr_schlick[i].log_rmse,
        );
    }
    // Measured on the 48-material test basis: the largest gap is the clear coat's (0.745 HDR,
    // 0.894 8-bit: its highlight is clipped and the fit sees only its shoulders). Before
    // clipped bins were taken at the reference where it already meets them, chrome came out
    // at 0.95 from 8-bit paint against 0.065. With the edge tint, chrome's HDR view is 0.0028
    // and its 8-bit view stays at 0.066 (0.063 since a prior decides one view's tint where
    // rounding hides it: its clipped peak, not its Fresnel, owns the rest); the principled
    // material's lobe, no brighter head-on than a dielectric, keeps Schlick's (with the prior:
    // 0.178 from HDR and 8-bit paint, against 0.162). Since a fit that explains the paint three
    // times as closely as the database's mean is taken (`+closer:3`), the plastic and the
    // Lambert surface are exact from HDR paint (0.112 and 0.084 before) and 0.008 and 0.0002
    // from 8-bit: the median over what HDR paint tells under Schlick's Fresnel is 0.113,
    // 8-bit's 0.118 (HDR with the edge tint: 0.082, chrome's exact peak now at the median).
    // With the grazing weight for one view the clear coat comes to 0.244 from HDR paint and
    // 0.336 from 8-bit paint (0.745 and 0.894 without it); since the weight also moves as far
    // as no bin changes by a thousandth, 0.296 from 8-bit paint.
    let hdr_told: Vec<_> = (0..MATERIALS)
        .map(|i| {
            if hdr[i].relative_rmse >= hdr_schlick[i].relative_rmse {
                hdr[i].clone()
            } else {
                hdr_schlick[i].clone()
            }
        })
        .collect();
    let median_hdr = median(&hdr_told, relative_rmse);
    let median_ldr = median(&ldr, relative_rmse);
    assert!(
        median_ldr <= 1.05 * median_hdr,
        "8-bit median relative RMSE {median_ldr:.4} against HDR {median_hdr:.4}"
    );
    for i in 0..MATERIALS {
        let label = material(HELD_OUT_SEED, i).label;
        let hdr_relative = hdr[i]
            .relative_rmse
            .max(hdr_schlick[i].relative_rmse)
            .max(hdr_unsplit[i].relative_rmse);
        let hdr_log = hdr[i]
            .log_rmse
            .max(hdr_schlick[i].log_rmse)
            .max(hdr_unsplit[i].log_rmse);
        assert!(
            ldr[i].relative_rmse <= 1.25 * hdr_relative + QUANTISATION_RELATIVE,
            "{label}: 8-bit relative RMSE {:.4} against HDR {hdr_relative:.4}",
            ldr[i].relative_rmse,
        );
        assert!(
            ldr[i].log_rmse <= 1.2 * hdr_log + QUANTISATION_LOG,
            "{label}: 8-bit log RMSE {:.4} against HDR {hdr_log:.4}",
            ldr[i].log_rmse,
        );
        assert!(
            ldr[i].relative_rmse <= 1.01 * ldr_schlick[i].relative_rmse
                && ldr[i].log_rmse <= 1.01 * ldr_schlick[i].log_rmse,
            "{label}: the edge tint made 8-bit paint worse: relative RMSE {:.4} against {:.4}, log RMSE {:.4} against {:.4}",
            ldr[i].relative_rmse,
            ldr_schlick[i].relative_rmse,
            ldr[i].log_rmse,
            ldr_schlick[i].log_rmse,
        );
    }
}

/// One figure of an evaluation.
type Metric = fn(&Evaluation) -> f64;

fn relative_rmse(e: &Evaluation) -> f64 {
    e.relative_rmse
}

fn log_rmse(e: &Evaluation) -> f64 {
    e.log_rmse
}

fn median(evaluations: &[Evaluation], field: impl Fn(&Evaluation) -> f64) -> f64 {
    let mut values: Vec<f64> = evaluations.iter().map(field).collect();
    values.sort_by(f64::total_cmp);
    let n = values.len();
    if n % 2 == 1 {
        values[n / 2]
    } else {
        0.5 * (values[n / 2 - 1] + values[n / 2])
    }
}

/// Issue 9's promise: an artist who paints one more view never gets a worse BRDF. Materials
/// the generator does not make (hand-built: layered paint, Minnaert, GTR, flop, forward
/// scattering, …), painted perfectly under the lights of the issue's measurement, one, two and
/// three views, reconstructed on the 48-material test basis.
///
/// After each added view the mean relative RMSE and the mean log RMSE must not rise, nor the
/// median relative RMSE or median log RMSE by more than 1%; no material's log RMSE may rise by
/// more than 4%, nor its relative RMSE grow by more than 20%. From one view to three, the
/// issue's bound holds for every material but the metal below: relative RMSE at most 10%
/// above one view's, and log RMSE no higher.
///
/// Measured on the default fitted reference: the median relative RMSE goes 0.105 → 0.075 →
/// 0.060 and the median log RMSE 0.164 → 0.074 → 0.065. The largest rises among the stepped
/// materials: a dark Minnaert's relative RMSE 0.098 → 0.108 (+10%) and forward scattering's
/// 0.039 → 0.040 (+3%) from two views to three.
///
/// One metal is held by a bound of its own instead of the steps, below what one lobe gives it
/// at every view count: the coated brushed metal (a clear coat over an anisotropic Beckmann
/// base), which no single lobe holds. The reference's haze (a sharp lobe over a broad one of
/// the same Fresnel, in the default since it made the bench's two-lobe gold exact) fits it far
/// better than one lobe, but the correction on top of it no longer gains with each view:
/// 0.062 → 0.056 → 0.060, log RMSE 0.164 → 0.161 → 0.170 (one lobe 0.101 → 0.121 → 0.126,
/// log RMSE 0.404 → 0.381 → 0.382).
///
/// The GTR metal (γ = 3, Kelemen's masking) was held likewise while the reference fitted it
/// a Beckmann lobe with a haze (0.092 → 0.103 → 0.119); with GTR's tails in the fit it
/// steps like the rest: 0.105 → 0.099 → 0.099, log RMSE 0.074 → 0.073 → 0.065.
///
/// It counts in the set's means and its log medians like every other material; the other
/// ten materials' median relative RMSE must not rise.
#[test]
fn every_added_view_helps_materials_unlike_the_database() {
    /// (material, relative RMSE bound, log RMSE bound) at every view count: about 5% above
    /// what is measured, so that a regression of that size fails.
    const OWN_BOUNDS: [(&str, f64, f64); 1] = [("hand-coated-brushed", 0.066, 0.179)];
    let own_bound = |name: &str| OWN_BOUNDS.iter().find(|(held, ..)| *held == name);
    const ISSUE_LIGHTS: [(f64, f64); 3] = [(45.0, 30.0), (60.0, 200.0), (20.0, 120.0)];
    let dir = tempfile::tempdir().unwrap();
    let materials = hand_built_materials(HAND_BUILT);
    let truths: Vec<SymTable> = materials.iter().map(|m| tabulate(&*m.brdf)).collect();
    let by_views: Vec<Vec<Evaluation>> = (1..=ISSUE_LIGHTS.len())
        .map(|views| {
            truths
                .iter()
                .map(|truth| {
                    evaluate(
                        truth,
                        &reconstruct_from_renders(truth, &ISSUE_LIGHTS[..views], dir.path()),
                    )
                })
                .collect()
        })
        .collect();
    for (m, material) in materials.iter().enumerate() {
        let relative: Vec<String> = by_views
            .iter()
            .map(|e| format!("{:.4}", e[m].relative_rmse))
            .collect();
        let log: Vec<String> = by_views
            .iter()
            .map(|e| format!("{:.4}", e[m].log_rmse))
            .collect();
        println!(
            "{:<28} relative RMSE {} log RMSE {}",
            material.name,
            relative.join(" → "),
            log.join(" → ")
        );
    }
    for (views, pair) in by_views.windows(2).enumerate() {
        let (before, after) = (&pair[0], &pair[1]);
        let step = format!("{} → {} views", views + 1, views + 2);
        let metrics: [(&str, Metric); 2] =
            [("relative RMSE", relative_rmse), ("log RMSE", log_rmse)];
        for (name, field) in metrics {
            assert!(
                mean(after, field) <= mean(before, field),
                "{step}: mean {name} rose from {:.4} to {:.4}",
                mean(before, field),
                mean(after, field)
            );
        }
        // The metals held by their own bounds sit near the set's median relative RMSE, so
        // their bounds (below) hold them there too.
        let stepped = |e: &[Evaluation]| -> Vec<Evaluation> {
            e.iter()
                .zip(&materials)
                .filter(|(_, material)| own_bound(&material.name).is_none())
                .map(|(e, _)| e.clone())
                .collect()
        };
        let (before_stepped, after_stepped) = (stepped(before), stepped(after));
        for (name, field) in metrics {
            let (before, after) = if name == "relative RMSE" {
                (&before_stepped[..], &after_stepped[..])
            } else {
                (&before[..], &after[..])
            };
            assert!(
                median(after, field) <= 1.01 * median(before, field),
                "{step}: median {name} rose from {:.4} to {:.4}",
                median(before, field),
                median(after, field)
            );
        }
        for (m, material) in materials.iter().enumerate() {
            if own_bound(&material.name).is_some() {
                continue;
            }
            assert!(
                after[m].log_rmse <= 1.04 * before[m].log_rmse,
                "{step}: {} log RMSE rose from {:.4} to {:.4}",
                material.name,
                before[m].log_rmse,
                after[m].log_rmse
            );
            assert!(
                after[m].relative_rmse <= 1.2 * before[m].relative_rmse,
                "{step}: {} relative RMSE grew from {:.4} to {:.4}",
                material.name,
                before[m].relative_rmse,
                after[m].relative_rmse
            );
        }
    }
    let (first, last) = (&by_views[0], &by_views[by_views.len() - 1]);
    for (m, material) in materials.iter().enumerate() {
        if let Some(&(_, relative_bound, log_bound)) = own_bound(&material.name) {
            for (views, e) in by_views.iter().enumerate() {
                assert!(
                    e[m].relative_rmse < relative_bound && e[m].log_rmse < log_bound,
                    "{} views: {} relative RMSE {:.4} (bound {relative_bound}), log RMSE {:.4} (bound {log_bound})",
                    views + 1,
                    material.name,
                    e[m].relative_rmse,
                    e[m].log_rmse
                );
            }
            continue;
        }
        assert!(
            last[m].relative_rmse <= 1.1 * first[m].relative_rmse,
            "1 → 3 views: {} relative RMSE grew from {:.4} to {:.4}",
            material.name,
            first[m].relative_rmse,
            last[m].relative_rmse
        );
        assert!(
            last[m].log_rmse <= first[m].log_rmse,
            "1 → 3 views: {} log RMSE rose from {:.4} to {:.4}",
            material.name,
            first[m].log_rmse,
            last[m].log_rmse
        );
    }
}

/// A polished metal (the bench's two-lobe gold: a sharp GGX lobe over a Beckmann haze, one
/// conductor Fresnel) from one view. One lobe settles between the peak and the glow, and where
/// the peak is clipped (8-bit paint) on the glow alone, so the peak it extrapolates above the
/// clip is far too low. The default reference keeps a haze beside the lobe and holds both.
/// Measured on the test basis (128² paintings): HDR 0.0000, 8-bit 0.0178; with one lobe 0.329
/// and 0.958.
#[test]
fn a_polished_metal_keeps_its_peak_from_one_clipped_view() {
    let dir = tempfile::tempdir().unwrap();
    let gold = hand_built_materials(HAND_BUILT)
        .into_iter()
        .find(|m| m.name == "hand-two-lobe-metal")
        .unwrap();
    let truth = tabulate(&*gold.brdf);
    let mut one_lobe = PriorMean::FITTED;
    if let PriorMean::Fitted { haze_margin, .. } = &mut one_lobe {
        *haze_margin = None;
    }
    let score = |extension, mean| {
        evaluate(
            &truth,
            &reconstruct_with_mean(&truth, &LIGHTS[..1], dir.path(), extension, mean),
        )
        .relative_rmse
    };
    let (hdr, ldr) = (
        score("exr", PriorMean::FITTED),
        score("png", PriorMean::FITTED),
    );
    let (hdr_one_lobe, ldr_one_lobe) = (score("exr", one_lobe), score("png", one_lobe));
    println!(
        "relative RMSE HDR {hdr:.4} 8-bit {ldr:.4} (one lobe: {hdr_one_lobe:.4} {ldr_one_lobe:.4})"
    );
    assert!(hdr < 0.01 && ldr < 0.02, "HDR {hdr:.4}, 8-bit {ldr:.4}");
    assert!(
        ldr_one_lobe > 10.0 * ldr,
        "one lobe's 8-bit view {ldr_one_lobe:.4}"
    );
}

/// A plastic whose lobe has a dielectric's exact Fresnel, as Cook and Torrance wrote it (GGX
/// α 0.075, η 1.64, V-cavity masking), painted under the issue's lights. Schlick's curve falls
/// a quarter short of the dielectric's at θ_d 60°, where the second light paints: a Schlick
/// reference bends its lobe to meet that view, and the correction carries the mismatch on to
/// the grazing mirror. The default reference fits the dielectric's own curve there, and every
/// added view helps. Measured on the test basis (128² paintings), relative RMSE one → two →
/// three views: 0.348 → 0.315 → 0.316; with Schlick's curve alone 0.348 → 0.518 → 0.509.
#[test]
fn a_dielectric_plastic_gains_from_every_view() {
    use burnish::materials::classic::CookTorrance;
    use burnish::materials::models::{Distribution, Fresnel};
    const ISSUE_LIGHTS: [(f64, f64); 3] = [(45.0, 30.0), (60.0, 200.0), (20.0, 120.0)];
    let truth = tabulate(&CookTorrance {
        diffuse: [0.057, 0.074, 0.075],
        distribution: Distribution::Ggx,
        alpha: 0.075,
        fresnel: Fresnel::Conductor {
            eta: [1.64; 3],
            k: [0.0; 3],
        },
        tint: [1.0; 3],
    });
    let mut schlick_only = PriorMean::FITTED;
    if let PriorMean::Fitted {
        dielectric_margin, ..
    } = &mut schlick_only
    {
        *dielectric_margin = None;
    }
    let dir = tempfile::tempdir().unwrap();
    let errors = |mean: PriorMean| -> Vec<f64> {
        (1..=ISSUE_LIGHTS.len())
            .map(|views| {
                let estimate =
                    reconstruct_with_mean(&truth, &ISSUE_LIGHTS[..views], dir.path(), "exr", mean);
                evaluate(&truth, &estimate).relative_rmse
            })
            .collect()
    };
    let (exact, schlick) = (errors(PriorMean::FITTED), errors(schlick_only));
    println!("relative RMSE, one to three views: dielectric {exact:.4?}, Schlick {schlick:.4?}");
    for step in exact.windows(2) {
        assert!(step[1] <= 1.1 * step[0], "{exact:?}");
    }
    assert!(schlick[1] > 1.1 * schlick[0], "{schlick:?}");
}
