//! The bottom status line: samples, bins, solve time, condition number, K, basis state.

use super::{BasisStatus, BurnishApp};

pub(super) fn show(app: &mut BurnishApp, ui: &mut egui::Ui) {
    let stats = app.doc.snapshot().stats;
    ui.horizontal_wrapped(|ui| {
        ui.label(format!("samples {}", stats.samples));
        ui.separator();
        ui.label(format!("observed bins {}", stats.observed_bins));
        ui.separator();
        let inconsistent = format!("inconsistent {}", stats.inconsistent_bins);
        if stats.inconsistent_bins > 0 {
            ui.colored_label(ui.visuals().warn_fg_color, inconsistent)
                .on_hover_text(
                    "Bins where views or strokes disagree; turn on the overlay to see them",
                );
        } else {
            ui.label(inconsistent);
        }
        ui.separator();
        ui.label(format!("skipped px {}", stats.skipped_pixels))
            .on_hover_text("Painted pixels in shadow or at grazing angles give no sample");
        ui.separator();
        ui.label(format!("cond {:.2e}", stats.condition_number));
        ui.separator();
        if app.doc.snapshot().fitting_mean {
            ui.label("fitting…").on_hover_text(
                "The prior's mean is being fitted to the paint; the preview updates when done",
            );
            ui.separator();
        }
        match app.doc.basis_status() {
            BasisStatus::Working { stage, fraction } => {
                ui.label(format!("basis: {stage}"));
                ui.add(
                    egui::ProgressBar::new(fraction)
                        .desired_width(140.0)
                        .show_percentage(),
                );
            }
            BasisStatus::Ready {
                components,
                outcome: crate::basis::CacheOutcome::NotStored { reason },
            } => {
                ui.colored_label(
                    ui.visuals().warn_fg_color,
                    format!("K {components} · basis ready, not cached"),
                )
                .on_hover_text(format!(
                    "The basis is used from memory; it could not be cached, so the next start \
                     builds it again: {reason}"
                ));
            }
            BasisStatus::Ready { components, .. } => {
                ui.label(format!("K {components} · basis ready"));
            }
            BasisStatus::Failed(e) => {
                ui.colored_label(ui.visuals().error_fg_color, format!("basis failed: {e}"));
            }
        }
        if app.doc.is_dirty() {
            ui.separator();
            ui.label("unsaved");
        }
        // Timings last: their width changes from frame to frame, and nothing should move with it.
        ui.separator();
        ui.label(format!("solve {:.2} ms", stats.update_ms));
        if let (Some(p50), Some(p95)) = (app.latency_percentile(0.5), app.latency_percentile(0.95))
        {
            ui.separator();
            ui.label(format!("latency p50 {p50:.0} ms · p95 {p95:.0} ms"))
                .on_hover_text(
                    "Pointer event to the first preview frame with the new coefficients",
                );
        }
    });
}
