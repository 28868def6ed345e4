//! The Lobe tab: polar plots of the lobe in the plane of incidence, pinned angles and the
//! reference's lobes.

use super::current_reconstruction;
use crate::app::BurnishApp;
use crate::inspect::{
    LobeScale, curves_bounds, incidence_plane, lobe_curve, lobe_floor, lobe_peak, viridis,
};
use crate::table::Rgb;
use egui::Color32;

/// Decades below the peak the lobe's log scale shows.
const LOBE_DECADES: u8 = 3;
/// The incidence angles offered for pinning beside the slider's.
const MAX_LOBE_ANGLES: usize = 6;

/// The lobes last plotted: what they were computed for, and per incidence angle the
/// reconstruction's and the reference's samples.
pub(super) struct LobeCache {
    key: (u64, Vec<u32>, u32, bool),
    angles: Vec<f32>,
    lobes: Vec<Vec<(f64, Rgb)>>,
    reference: Vec<Vec<(f64, Rgb)>>,
    /// The plot was autoscaled to these lobes.
    scaled: bool,
    scale: LobeScale,
}

/// Colours for several lobes at once: spread over viridis, skipping its darkest end (it
/// hides on the plot's dark background).
fn lobe_colour(i: usize, count: usize) -> Color32 {
    let t = if count <= 1 {
        0.7
    } else {
        0.3 + 0.7 * i as f32 / (count - 1) as f32
    };
    let [r, g, b] = viridis(t).map(|c| (c * 255.0).round() as u8);
    Color32::from_rgb(r, g, b)
}

pub(super) fn lobe_tab(app: &mut BurnishApp, ui: &mut egui::Ui) {
    ui.horizontal_wrapped(|ui| {
        ui.add(
            egui::Slider::new(&mut app.lobe_theta_deg, 0.0..=89.0)
                .text("θ in")
                .suffix("°"),
        );
        ui.add(
            egui::Slider::new(&mut app.lobe_phi_deg, 0.0..=359.0)
                .text("φ in")
                .suffix("°"),
        );
        let state = &mut app.preview_state;
        let theta = app.lobe_theta_deg.round();
        if ui
            .add_enabled(
                state.lobe_angles.len() < MAX_LOBE_ANGLES && !state.lobe_angles.contains(&theta),
                egui::Button::new("+ pin θ").small(),
            )
            .on_hover_text("Keep this incidence angle in the plot while the slider moves on")
            .clicked()
        {
            state.lobe_angles.push(theta);
        }
    });
    ui.horizontal_wrapped(|ui| {
        let state = &mut app.preview_state;
        ui.selectable_value(&mut state.lobe_scale, LobeScale::Linear, "linear");
        ui.selectable_value(
            &mut state.lobe_scale,
            LobeScale::Log {
                decades: LOBE_DECADES,
            },
            "log",
        )
        .on_hover_text(format!(
            "Radius: log10 of ρ·cos θ_out, {LOBE_DECADES} decades below the peak"
        ));
        let mut unpin = None;
        for (i, angle) in state.lobe_angles.iter().enumerate() {
            if ui
                .small_button(format!("{angle:.0}° ×"))
                .on_hover_text("Unpin")
                .clicked()
            {
                unpin = Some(i);
            }
        }
        if let Some(i) = unpin {
            state.lobe_angles.remove(i);
        }
    });
    let mut angles = vec![app.lobe_theta_deg];
    angles.extend(
        app.preview_state
            .lobe_angles
            .iter()
            .filter(|a| (**a - app.lobe_theta_deg).abs() > 0.5),
    );
    let version = app.doc.snapshot().version;
    let has_reference = app.preview_state.reference.is_some();
    let key = (
        version,
        angles.iter().map(|a| a.to_bits()).collect::<Vec<_>>(),
        app.lobe_phi_deg.to_bits(),
        has_reference,
    );
    let scale = app.preview_state.lobe_scale;
    let stale = app.preview_state.lobe.as_ref().is_none_or(|l| l.key != key);
    if stale && let Some(recon) = current_reconstruction(app) {
        let phi = app.lobe_phi_deg as f64;
        let eval = |l, v| recon.eval(l, v);
        let lobes = angles
            .iter()
            .map(|&t| incidence_plane(&eval, t as f64, phi))
            .collect();
        let reference = match &app.preview_state.reference {
            Some(r) => {
                let table = r.table.clone();
                let lookup = move |l, v| table.get(l, v);
                angles
                    .iter()
                    .map(|&t| incidence_plane(&lookup, t as f64, phi))
                    .collect()
            }
            None => Vec::new(),
        };
        app.preview_state.lobe = Some(LobeCache {
            key,
            angles: angles.clone(),
            lobes,
            reference,
            scaled: false,
            scale,
        });
    }
    let Some(cache) = &mut app.preview_state.lobe else {
        ui.label("The lobe appears when the basis is ready.");
        return;
    };
    if cache.scale != scale {
        cache.scale = scale;
        cache.scaled = false;
    }
    let single = cache.angles.len() == 1;
    ui.label(if single {
        "ρ·cos θ_out in the plane of incidence, per channel (polar; light from the left)"
    } else {
        "luminance of ρ·cos θ_out in the plane of incidence (polar; light from the left)"
    });
    let peak = lobe_peak(
        cache
            .lobes
            .iter()
            .chain(&cache.reference)
            .map(|l| l.as_slice()),
    );
    let floor = lobe_floor(scale, peak);
    // (name, points, colour, dashed)
    let mut curves: Vec<(String, Vec<[f64; 2]>, Color32, bool)> = Vec::new();
    let channel_colours = [
        Color32::from_rgb(230, 80, 80),
        Color32::from_rgb(80, 200, 80),
        Color32::from_rgb(90, 120, 240),
    ];
    for (i, (theta, lobe)) in cache.angles.iter().zip(&cache.lobes).enumerate() {
        if single {
            for c in 0..3 {
                curves.push((
                    ["R", "G", "B"][c].into(),
                    lobe_curve(lobe, Some(c), scale, floor),
                    channel_colours[c],
                    false,
                ));
            }
        } else {
            curves.push((
                format!("θ in {theta:.0}°"),
                lobe_curve(lobe, None, scale, floor),
                lobe_colour(i, cache.angles.len()),
                false,
            ));
        }
    }
    for (i, (theta, lobe)) in cache.angles.iter().zip(&cache.reference).enumerate() {
        let colour = if single {
            Color32::from_gray(220)
        } else {
            lobe_colour(i, cache.angles.len())
        };
        curves.push((
            format!("reference θ in {theta:.0}°"),
            lobe_curve(lobe, None, scale, floor),
            colour,
            true,
        ));
    }
    let (min, max) = curves_bounds(curves.iter().map(|c| c.1.as_slice()));
    let reach = (max[0] - min[0]).max(max[1] - min[1]) * 0.5;
    let rescale = !cache.scaled;
    cache.scaled = true;
    let log_rings = match scale {
        LobeScale::Log { decades } => decades,
        LobeScale::Linear => 0,
    };
    let angles_drawn = cache.angles.clone();
    egui_plot::Plot::new("lobe")
        .data_aspect(1.0)
        .allow_scroll(false)
        .legend(egui_plot::Legend::default())
        .show(ui, |plot| {
            if rescale {
                plot.set_plot_bounds(egui_plot::PlotBounds::from_min_max(min, max));
            }
            // Decade rings of the log scale, labelled by the value they stand for (unnamed, so
            // that the legend lists only the lobes).
            for ring in 1..=log_rings {
                let r = f64::from(ring);
                let circle: Vec<[f64; 2]> = (0..=90)
                    .map(|k| {
                        let t = (k as f64 * 2.0 - 90.0).to_radians();
                        [r * t.sin(), r * t.cos()]
                    })
                    .collect();
                plot.line(
                    egui_plot::Line::new("", circle)
                        .color(Color32::from_gray(90))
                        .style(egui_plot::LineStyle::dotted_dense()),
                );
                plot.text(
                    egui_plot::Text::new(
                        "",
                        egui_plot::PlotPoint::new(0.0, r),
                        format!("1e{}", floor as i32 + ring as i32),
                    )
                    .color(Color32::from_gray(150))
                    .anchor(egui::Align2::LEFT_BOTTOM),
                );
            }
            for (name, points, colour, dashed) in curves {
                let mut line = egui_plot::Line::new(name, points).color(colour);
                if dashed {
                    line = line.style(egui_plot::LineStyle::dashed_loose());
                }
                plot.line(line);
            }
            for (i, theta) in angles_drawn.iter().enumerate() {
                let t = (*theta as f64).to_radians();
                let colour = if single {
                    Color32::from_rgb(255, 220, 120)
                } else {
                    lobe_colour(i, angles_drawn.len())
                };
                // The light's direction, unnamed: the lobe of the same colour names it.
                plot.line(
                    egui_plot::Line::new("", vec![[0.0, 0.0], [-t.sin() * reach, t.cos() * reach]])
                        .color(colour.gamma_multiply(0.6)),
                );
            }
        });
}
