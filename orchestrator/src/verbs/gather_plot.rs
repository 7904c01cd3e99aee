//! The PNG of a gather (plotters, bitmap backend). Text needs a TrueType font: the first of
//! `MCC_PLOT_FONT` and a few usual system paths that loads is registered with plotters'
//! `ab_glyph` renderer; without one the plot is drawn without any text (axes, grid, curves).

use std::path::Path;
use std::sync::OnceLock;

use anyhow::{anyhow, Result};
use plotters::prelude::*;

use super::Recording;

/// Environment variable naming a TrueType font file for plot text (`none`: no text).
pub const FONT_ENV: &str = "MCC_PLOT_FONT";

const FONT_PATHS: &[&str] = &[
    "/usr/share/fonts/truetype/dejavu/DejaVuSans.ttf",
    "/usr/share/fonts/TTF/DejaVuSans.ttf",
    "/usr/share/fonts/dejavu/DejaVuSans.ttf",
    "/usr/share/fonts/truetype/liberation/LiberationSans-Regular.ttf",
    "/usr/share/fonts/liberation/LiberationSans-Regular.ttf",
    "/usr/share/fonts/truetype/freefont/FreeSans.ttf",
    "/usr/share/fonts/noto/NotoSans-Regular.ttf",
    "/usr/share/fonts/truetype/noto/NotoSans-Regular.ttf",
];

/// Register a font as "sans-serif" once; whether one is available.
fn font() -> bool {
    static OK: OnceLock<bool> = OnceLock::new();
    *OK.get_or_init(|| {
        let env = std::env::var(FONT_ENV).ok();
        if env.as_deref() == Some("none") {
            return false;
        }
        env.iter()
            .map(String::as_str)
            .chain(FONT_PATHS.iter().copied())
            .any(|p| {
                let Ok(bytes) = std::fs::read(p) else {
                    return false;
                };
                if bytes.len() > 64 << 20 {
                    return false;
                }
                let bytes: &'static [u8] = Box::leak(bytes.into_boxed_slice());
                plotters::style::register_font("sans-serif", FontStyle::Normal, bytes).is_ok()
            })
    })
}

const COLORS: [RGBColor; 8] = [
    RGBColor(31, 119, 180),
    RGBColor(214, 39, 40),
    RGBColor(44, 160, 44),
    RGBColor(255, 127, 14),
    RGBColor(148, 103, 189),
    RGBColor(140, 86, 75),
    RGBColor(227, 119, 194),
    RGBColor(23, 190, 207),
];

/// Draw `rec` into `path` (1000 x 600): actual position solid, commanded thin and light, per
/// motor, against time in ms. Returns whether text (title, labels, legend) was drawn.
pub fn draw(rec: &Recording, path: &Path, title: &str) -> Result<bool> {
    let text = font();
    draw_with(rec, path, title, text)?;
    Ok(text)
}

/// [`draw`] with text on or off (off needs no font).
pub fn draw_with(rec: &Recording, path: &Path, title: &str, text: bool) -> Result<()> {
    let err = |e: &dyn std::fmt::Display| anyhow!("plot: {e}");
    let root = BitMapBackend::new(path, (1000, 600)).into_drawing_area();
    root.fill(&WHITE).map_err(|e| err(&e))?;
    let step = rec.cycle_ms * f64::from(rec.period);
    let step = if step > 0.0 { step } else { 1.0 };
    let t_end = (rec.samples.len().max(2) - 1) as f64 * step;
    let (mut lo, mut hi) = (f64::INFINITY, f64::NEG_INFINITY);
    for (c, a) in rec.samples.iter().flatten() {
        lo = lo.min(c.min(*a));
        hi = hi.max(c.max(*a));
    }
    if !lo.is_finite() || !hi.is_finite() {
        (lo, hi) = (0.0, 1.0);
    }
    let pad = ((hi - lo) * 0.05).max(1.0);
    let mut b = ChartBuilder::on(&root);
    b.margin(20);
    if text {
        b.caption(format!("mcc gather: {title}"), ("sans-serif", 24))
            .x_label_area_size(45)
            .y_label_area_size(80);
    } else {
        b.x_label_area_size(0).y_label_area_size(0);
    }
    let mut chart = b
        .build_cartesian_2d(0.0..t_end, (lo - pad)..(hi + pad))
        .map_err(|e| err(&e))?;
    if text {
        chart
            .configure_mesh()
            .x_desc("time (ms)")
            .y_desc("position (counts)")
            .label_style(("sans-serif", 14))
            .draw()
            .map_err(|e| err(&e))?;
    } else {
        // No font: a frame and a 10 x 10 grid drawn as plain lines.
        let (y0, y1) = (lo - pad, hi + pad);
        let grid = (0..=10).flat_map(|i| {
            let f = f64::from(i) / 10.0;
            [
                vec![(f * t_end, y0), (f * t_end, y1)],
                vec![(0.0, y0 + f * (y1 - y0)), (t_end, y0 + f * (y1 - y0))],
            ]
        });
        let style = |i: usize| {
            if !(2..20).contains(&i) {
                BLACK.stroke_width(1)
            } else {
                BLACK.mix(0.15).stroke_width(1)
            }
        };
        chart
            .draw_series(grid.enumerate().map(|(i, p)| PathElement::new(p, style(i))))
            .map_err(|e| err(&e))?;
    }
    for (k, m) in rec.motors.iter().enumerate() {
        let color = COLORS[k % COLORS.len()];
        let pts = |pick: fn(&(f64, f64)) -> f64| {
            rec.samples
                .iter()
                .enumerate()
                .filter_map(move |(i, row)| row.get(k).map(|v| (i as f64 * step, pick(v))))
        };
        let light = color.mix(0.45).stroke_width(1);
        let cmd = chart
            .draw_series(LineSeries::new(pts(|v| v.0), light))
            .map_err(|e| err(&e))?;
        if text {
            cmd.label(format!("motor {m} commanded"))
                .legend(move |(x, y)| PathElement::new([(x, y), (x + 20, y)], light));
        }
        let solid = color.stroke_width(2);
        let act = chart
            .draw_series(LineSeries::new(pts(|v| v.1), solid))
            .map_err(|e| err(&e))?;
        if text {
            act.label(format!("motor {m} actual"))
                .legend(move |(x, y)| PathElement::new([(x, y), (x + 20, y)], solid));
        }
    }
    if text {
        chart
            .configure_series_labels()
            .position(SeriesLabelPosition::LowerRight)
            .label_font(("sans-serif", 14))
            .background_style(WHITE.mix(0.8))
            .border_style(BLACK)
            .draw()
            .map_err(|e| err(&e))?;
    }
    root.present().map_err(|e| err(&e))?;
    Ok(())
}
