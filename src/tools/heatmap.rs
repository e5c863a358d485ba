//! Debug images that show where the adaptive queues spent rays: the paper's green
//! refined pixels (Figures 1, 2, 10), blue penumbra points (Figure 3), and rays per
//! pixel on a colour scale with a legend.

use glam::Vec3;

use crate::color::to_display8;
use crate::film::{Heat, Image};

/// The heatmaps `--heatmap KIND=PATH` can write; the command line knows them by their
/// value names (`aa`, `penumbra`, `rays`).
#[derive(Clone, Copy, Debug, PartialEq, Eq, clap::ValueEnum)]
pub enum HeatmapKind {
    /// The render with pixels the adaptive AA refined tinted green.
    Aa,
    /// The render with pixels whose shading points entered the penumbra queue tinted blue
    /// (stronger where a larger fraction of them did).
    Penumbra,
    /// Rays per pixel (all kinds) on a logarithmic colour scale, with a legend below.
    Rays,
}

/// An 8-bit RGB picture.
pub struct Picture {
    /// Width.
    pub width: u32,
    /// Height.
    pub height: u32,
    /// RGB bytes, row-major.
    pub rgb: Vec<u8>,
}

fn display(image: &Image) -> Vec<[f32; 3]> {
    image.pixels.iter().map(|p| [p.x, p.y, p.z].map(|c| to_display8(c) as f32 / 255.0)).collect()
}

fn blend(base: [f32; 3], tint: [f32; 3], a: f32) -> [f32; 3] {
    [0, 1, 2].map(|i| base[i] * (1.0 - a) + tint[i] * a)
}

fn to_bytes(px: &[[f32; 3]]) -> Vec<u8> {
    px.iter().flat_map(|p| p.map(|c| (c.clamp(0.0, 1.0) * 255.0 + 0.5) as u8)).collect()
}

/// Draws the heatmap of `kind`.
pub fn draw(kind: HeatmapKind, image: &Image, heat: &Heat) -> Picture {
    let (w, h) = (image.width, image.height);
    match kind {
        HeatmapKind::Aa => {
            let px: Vec<[f32; 3]> = display(image)
                .into_iter()
                .zip(&heat.level)
                .map(|(p, &l)| if l > 0 { blend(p, [0.0, 1.0, 0.0], 0.6) } else { p })
                .collect();
            Picture { width: w, height: h, rgb: to_bytes(&px) }
        }
        HeatmapKind::Penumbra => {
            let px: Vec<[f32; 3]> = display(image)
                .into_iter()
                .enumerate()
                .map(|(i, p)| {
                    let (n, pen) = (heat.points[i], heat.penumbra[i]);
                    if pen > 0.0 && n > 0.0 {
                        blend(p, [0.1, 0.3, 1.0], 0.35 + 0.5 * (pen / n).min(1.0))
                    } else {
                        p
                    }
                })
                .collect();
            Picture { width: w, height: h, rgb: to_bytes(&px) }
        }
        HeatmapKind::Rays => rays_map(w, h, &heat.rays),
    }
}

/// A perceptual-ish colour scale (dark blue → teal → yellow → white) for t in [0, 1].
pub fn scale(t: f32) -> [f32; 3] {
    const STOPS: [Vec3; 5] = [
        Vec3::new(0.05, 0.03, 0.25),
        Vec3::new(0.15, 0.35, 0.65),
        Vec3::new(0.15, 0.7, 0.55),
        Vec3::new(0.95, 0.85, 0.2),
        Vec3::new(1.0, 1.0, 0.95),
    ];
    let x = t.clamp(0.0, 1.0) * (STOPS.len() - 1) as f32;
    let i = (x as usize).min(STOPS.len() - 2);
    STOPS[i].lerp(STOPS[i + 1], x - i as f32).to_array()
}

/// Position of `v` on the legend's logarithmic axis from `lo` to `hi`.
fn log_t(v: f32, lo: f32, hi: f32) -> f32 {
    if hi <= lo {
        return 0.5;
    }
    ((v.max(lo) / lo).ln() / (hi / lo).ln()).clamp(0.0, 1.0)
}

const LEGEND: u32 = 22;

fn rays_map(w: u32, h: u32, rays: &[f32]) -> Picture {
    let lo = rays.iter().copied().filter(|&r| r > 0.0).fold(f32::INFINITY, f32::min).clamp(1e-3, f32::MAX);
    let hi = rays.iter().copied().fold(0.0f32, f32::max).max(lo);
    let mut px: Vec<[f32; 3]> =
        rays.iter().map(|&r| if r > 0.0 { scale(log_t(r, lo, hi)) } else { [0.0; 3] }).collect();
    // Legend: a colour bar across the width, with the low, middle and high values.
    let height = h + LEGEND;
    px.resize((w * height) as usize, [0.0; 3]);
    let bar = (h + 2)..(h + 8);
    for y in bar {
        for x in 0..w {
            px[(y * w + x) as usize] = scale(x as f32 / (w.max(2) - 1) as f32);
        }
    }
    let mid = (lo * hi).sqrt();
    let labels = [(lo, 0u32, 0), (mid, w / 2, 1), (hi, w, 2)];
    for (v, x, align) in labels {
        let text = number(v);
        let tw = text_width(&text);
        let x0 = match align {
            0 => 1,
            1 => x.saturating_sub(tw / 2),
            _ => x.saturating_sub(tw + 1),
        };
        draw_text(&mut px, w, height, x0, h + 11, &text);
    }
    Picture { width: w, height, rgb: to_bytes(&px) }
}

fn number(v: f32) -> String {
    if v >= 100.0 || v.fract() == 0.0 {
        format!("{}", v.round() as u64)
    } else if v >= 10.0 {
        format!("{v:.1}")
    } else {
        format!("{v:.2}")
    }
}

/// 3×5 glyphs for digits and the decimal point, one row per 3 bits.
fn glyph(c: char) -> [u8; 5] {
    match c {
        '0' => [7, 5, 5, 5, 7],
        '1' => [2, 6, 2, 2, 7],
        '2' => [7, 1, 7, 4, 7],
        '3' => [7, 1, 7, 1, 7],
        '4' => [5, 5, 7, 1, 1],
        '5' => [7, 4, 7, 1, 7],
        '6' => [7, 4, 7, 5, 7],
        '7' => [7, 1, 1, 1, 1],
        '8' => [7, 5, 7, 5, 7],
        '9' => [7, 5, 7, 1, 7],
        '.' => [0, 0, 0, 0, 2],
        _ => [0; 5],
    }
}

const PX: u32 = 2;

fn text_width(text: &str) -> u32 {
    text.chars().count() as u32 * 4 * PX
}

fn draw_text(px: &mut [[f32; 3]], w: u32, h: u32, x0: u32, y0: u32, text: &str) {
    for (i, c) in text.chars().enumerate() {
        let g = glyph(c);
        for (row, bits) in g.iter().enumerate() {
            for col in 0..3 {
                if bits & (4 >> col) == 0 {
                    continue;
                }
                for dy in 0..PX {
                    for dx in 0..PX {
                        let x = x0 + (i as u32 * 4 + col) * PX + dx;
                        let y = y0 + row as u32 * PX + dy;
                        if x < w && y < h {
                            px[(y * w + x) as usize] = [1.0; 3];
                        }
                    }
                }
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn aa_map_tints_only_refined_pixels() {
        let image = Image { width: 2, height: 1, pixels: vec![Vec3::ZERO, Vec3::ZERO] };
        let heat = Heat { rays: vec![5.0, 60.0], level: vec![0, 3], points: vec![0.0; 2], penumbra: vec![0.0; 2] };
        let p = draw(HeatmapKind::Aa, &image, &heat);
        assert_eq!(&p.rgb[0..3], &[0, 0, 0]);
        assert!(p.rgb[4] > 100 && p.rgb[3] == 0 && p.rgb[5] == 0, "{:?}", &p.rgb[3..6]);
    }

    #[test]
    fn rays_map_has_a_legend_and_orders_colours() {
        let image = Image { width: 40, height: 2, pixels: vec![Vec3::ZERO; 80] };
        let mut heat = Heat { rays: vec![5.0; 80], level: vec![0; 80], points: vec![0.0; 80], penumbra: vec![0.0; 80] };
        heat.rays[1] = 500.0;
        let p = draw(HeatmapKind::Rays, &image, &heat);
        assert_eq!(p.height, 2 + LEGEND);
        let lum = |i: usize| p.rgb[3 * i] as u32 + p.rgb[3 * i + 1] as u32 + p.rgb[3 * i + 2] as u32;
        assert!(lum(1) > lum(0), "more rays must read brighter");
    }
}
