//! The Pareto plot: mean relative RMSE against time per reconstruction, one point per method,
//! drawn with plotters into an RGB buffer and encoded as PNG.

use super::Method;
use image::ImageEncoder;
use plotters::prelude::*;
use std::sync::Once;

const WIDTH: u32 = 1400;
const HEIGHT: u32 = 900;
/// The font family name the plot's text asks for.
pub(crate) const FONT: &str = "sans-serif";

/// One method over every material: a point of the plot, and a row of the report's tables and
/// figures (`bench::report` and `bench` re-export it).
#[derive(Clone, Debug, PartialEq)]
pub struct Aggregate {
    pub method: Method,
    pub axis: &'static str,
    pub materials: usize,
    pub mean_relative_rmse: f64,
    pub median_relative_rmse: f64,
    pub mean_log_rmse: f64,
    pub mean_median_psnr_db: f64,
    pub mean_time_ms: f64,
    /// Mean relative RMSE over the materials Lambert + GGX does not describe.
    pub mean_relative_rmse_not_lambert_ggx: f64,
    /// Mean relative RMSE over the materials Lambert + GGX describes.
    pub mean_relative_rmse_lambert_ggx: f64,
}

pub(crate) fn register_font() -> Result<(), String> {
    static REGISTER: Once = Once::new();
    let mut result = Ok(());
    REGISTER.call_once(|| {
        result = plotters::style::register_font(
            FONT,
            FontStyle::Normal,
            epaint_default_fonts::UBUNTU_LIGHT,
        )
        .map_err(|_| "the bundled Ubuntu Light font does not parse".to_string());
    });
    result
}

/// Colour of a sweep axis.
fn axis_colour(axis: &str) -> RGBColor {
    match axis {
        "paper" => RGBColor(0, 0, 0),
        "K" => RGBColor(31, 119, 180),
        "regularisation" => RGBColor(255, 127, 14),
        "views" => RGBColor(44, 160, 44),
        "resolution" => RGBColor(148, 103, 189),
        "paint" => RGBColor(140, 86, 75),
        "policy" => RGBColor(227, 119, 194),
        "oracle" => RGBColor(214, 39, 40),
        _ => RGBColor(127, 127, 127),
    }
}

/// Round values (1, 2, 5 × 10ⁿ) inside [lo, hi]: a log axis's ticks.
pub(crate) fn ticks(lo: f64, hi: f64) -> Vec<f64> {
    let mut out = Vec::new();
    let mut decade = 10f64.powf(lo.log10().floor());
    while decade <= hi {
        for m in [1.0, 2.0, 5.0] {
            let v = m * decade;
            if (lo..=hi).contains(&v) {
                out.push(v);
            }
        }
        decade *= 10.0;
    }
    out
}

/// A tick label with about two significant digits.
pub(crate) fn tick(v: f64) -> String {
    let digits = (1 - v.abs().max(1e-12).log10().floor() as i32).max(0) as usize;
    format!("{v:.digits$}")
}

/// Indices of the points no other point beats in both time and error, fastest first.
pub fn pareto_front(points: &[(f64, f64)]) -> Vec<usize> {
    let mut order: Vec<usize> = (0..points.len()).collect();
    order.sort_by(|&a, &b| {
        points[a]
            .0
            .total_cmp(&points[b].0)
            .then(points[a].1.total_cmp(&points[b].1))
    });
    let mut front = Vec::new();
    let mut best = f64::INFINITY;
    for i in order {
        if points[i].1 < best {
            best = points[i].1;
            front.push(i);
        }
    }
    front
}

/// The PNG bytes of the plot; `subtitle` names the machine.
pub fn pareto_png(aggregates: &[Aggregate], subtitle: &str) -> Result<Vec<u8>, String> {
    register_font()?;
    let usable: Vec<&Aggregate> = aggregates
        .iter()
        .filter(|a| {
            a.mean_time_ms.is_finite()
                && a.mean_time_ms > 0.0
                && a.mean_relative_rmse.is_finite()
                && a.mean_relative_rmse > 0.0
        })
        .collect();
    let points: Vec<(f64, f64)> = usable
        .iter()
        .map(|a| (a.mean_time_ms, a.mean_relative_rmse))
        .collect();
    let (mut x0, mut x1, mut y0, mut y1) = (f64::MAX, f64::MIN, f64::MAX, f64::MIN);
    for &(x, y) in &points {
        (x0, x1, y0, y1) = (x0.min(x), x1.max(x), y0.min(y), y1.max(y));
    }
    if points.is_empty() {
        (x0, x1, y0, y1) = (1.0, 10.0, 0.1, 1.0);
    }
    // Room on the right for the labels, which are written after their points.
    let (x0, x1) = (x0 / 1.5, x1 * 4.0);
    let (y0, y1) = (y0 / 1.3, y1 * 1.3);

    let mut buffer = vec![0u8; (WIDTH * HEIGHT * 3) as usize];
    {
        let err = |e: &dyn std::fmt::Display| e.to_string();
        let root = BitMapBackend::with_buffer(&mut buffer, (WIDTH, HEIGHT)).into_drawing_area();
        root.fill(&WHITE).map_err(|e| err(&e))?;
        let (title, body) = root.split_vertically(70);
        title
            .draw(&Text::new(
                "Burnish: reconstruction error against time (held-out materials, mean)",
                (20, 10),
                (FONT, 30).into_font(),
            ))
            .map_err(|e| err(&e))?;
        title
            .draw(&Text::new(
                subtitle.to_string(),
                (20, 45),
                (FONT, 18).into_font().color(&RGBColor(90, 90, 90)),
            ))
            .map_err(|e| err(&e))?;
        let mut chart = ChartBuilder::on(&body)
            .margin(20)
            .x_label_area_size(55)
            .y_label_area_size(80)
            .build_cartesian_2d(
                (x0..x1).log_scale().with_key_points(ticks(x0, x1)),
                (y0..y1).log_scale().with_key_points(ticks(y0, y1)),
            )
            .map_err(|e| err(&e))?;
        chart
            .configure_mesh()
            .x_desc("time per reconstruction, samples to full table (ms, log)")
            .y_desc("relative RMSE of ρ·cosθl·cosθv (log)")
            .label_style((FONT, 18))
            .axis_desc_style((FONT, 20))
            .x_label_formatter(&|x| tick(*x))
            .y_label_formatter(&|y| tick(*y))
            .draw()
            .map_err(|e| err(&e))?;
        let front: Vec<(f64, f64)> = pareto_front(&points).iter().map(|&i| points[i]).collect();
        chart
            .draw_series(LineSeries::new(
                front.iter().copied(),
                ShapeStyle::from(&RGBColor(180, 180, 180)).stroke_width(3),
            ))
            .map_err(|e| err(&e))?
            .label("Pareto front")
            .legend(|(x, y)| {
                PathElement::new(
                    vec![(x, y), (x + 20, y)],
                    RGBColor(180, 180, 180).stroke_width(3),
                )
            });
        let mut axes: Vec<&str> = Vec::new();
        for a in &usable {
            if !axes.contains(&a.axis) {
                axes.push(a.axis);
            }
        }
        for axis in axes {
            let colour = axis_colour(axis);
            let of: Vec<&&Aggregate> = usable.iter().filter(|a| a.axis == axis).collect();
            chart
                .draw_series(of.iter().map(|a| {
                    let size = if axis == "paper" { 9 } else { 6 };
                    Circle::new(
                        (a.mean_time_ms, a.mean_relative_rmse),
                        size,
                        colour.filled(),
                    )
                }))
                .map_err(|e| err(&e))?
                .label(axis)
                .legend(move |(x, y)| Circle::new((x + 10, y), 6, colour.filled()));
            chart
                .draw_series(of.iter().map(|a| {
                    Text::new(
                        a.method.label(),
                        (a.mean_time_ms * 1.04, a.mean_relative_rmse * 1.015),
                        (FONT, 14).into_font().color(&colour),
                    )
                }))
                .map_err(|e| err(&e))?;
        }
        chart
            .configure_series_labels()
            .position(SeriesLabelPosition::LowerRight)
            .label_font((FONT, 18))
            .background_style(WHITE.mix(0.85))
            .border_style(BLACK)
            .draw()
            .map_err(|e| err(&e))?;
        root.present().map_err(|e| err(&e))?;
    }
    encode_png(&buffer, WIDTH, HEIGHT)
}

/// The PNG bytes of a `width × height` RGB buffer a plot was drawn into.
pub(crate) fn encode_png(buffer: &[u8], width: u32, height: u32) -> Result<Vec<u8>, String> {
    let mut png = Vec::new();
    image::codecs::png::PngEncoder::new(&mut png)
        .write_image(buffer, width, height, image::ExtendedColorType::Rgb8)
        .map_err(|e| e.to_string())?;
    Ok(png)
}
