//! FLIP's tests: colour transforms against known values, filter normalisation,
//! properties of the error (zero for identical images, symmetry, mirroring,
//! bounds), and maps against NVIDIA's reference implementation.

use super::*;
use crate::color::srgb_decode;

fn assert_close(actual: f32, expected: f32, tol: f32, what: &str) {
    assert!((actual - expected).abs() <= tol, "{what}: got {actual}, expected {expected} ± {tol}");
}

fn assert_vec_close(actual: Vec3, expected: Vec3, tol: f32, what: &str) {
    assert!(actual.abs_diff_eq(expected, tol), "{what}: got {actual}, expected {expected} ± {tol}");
}

fn uniform(width: usize, height: usize, c: [f32; 3]) -> Vec<[f32; 3]> {
    vec![c; width * height]
}

// Integer patterns, so that the Python script that produced the reference
// values below builds bit-identical inputs.
fn noise(width: usize, height: usize, seed: usize) -> Vec<[f32; 3]> {
    let mut img = Vec::with_capacity(width * height);
    for y in 0..height {
        for x in 0..width {
            img.push(std::array::from_fn(|c| ((x * 7 + y * 13 + c * 5 + seed * (x * y % 3)) % 17) as f32 / 16.0));
        }
    }
    img
}

fn gradient(width: usize, height: usize, square: bool) -> Vec<[f32; 3]> {
    let mut img = Vec::with_capacity(width * height);
    for y in 0..height {
        for x in 0..width {
            let inside = (width / 3..2 * width / 3).contains(&x) && (height / 3..2 * height / 3).contains(&y);
            img.push(if square && inside {
                [0.75; 3]
            } else {
                [x as f32 / (width - 1) as f32, y as f32 / (height - 1) as f32, 0.25]
            });
        }
    }
    img
}

fn mirror_x<T: Copy>(img: &[T], width: usize) -> Vec<T> {
    img.chunks_exact(width).flat_map(|row| row.iter().rev().copied()).collect()
}

fn transpose<T: Copy>(img: &[T], width: usize, height: usize) -> Vec<T> {
    (0..width).flat_map(|x| (0..height).map(move |y| img[y * width + x])).collect()
}

#[test]
fn default_ppd_is_a_4k_monitor_at_arms_length() {
    // 3840·π/180; the reference tool reports it as 67.0206 and names it "67 PPD".
    assert_close(ppd_default(), 67.020_65, 1e-4, "ppd_default");
    assert_eq!(ppd_default().round(), 67.0);
}

#[test]
fn srgb_decoding_matches_known_values() {
    assert_close(srgb_decode(0.5), 0.214_041, 1e-5, "sRGB 0.5");
    assert_eq!(srgb_decode(0.0), 0.0);
    assert_close(srgb_decode(1.0), 1.0, 1e-6, "sRGB 1");
    // Linear toe below the 0.04045 threshold.
    assert_close(srgb_decode(0.04), 0.04 / 12.92, 1e-9, "sRGB 0.04");
    // The two branches meet at the threshold.
    assert_close(srgb_decode(0.040_451), srgb_decode(0.04045), 1e-6, "continuity");
}

#[test]
fn linear_white_maps_to_d65_in_xyz() {
    let white = linear_rgb_to_xyz(Vec3::ONE);
    assert_vec_close(white, Vec3::new(0.9505, 1.0, 1.089), 1e-4, "XYZ of white");
    assert_vec_close(white, D65_WHITE, 1e-6, "XYZ of white vs D65_WHITE");
    // Y of the primaries are the Rec. 709 luma weights.
    assert_close(linear_rgb_to_xyz(Vec3::X).y, 0.2126, 1e-4, "Y of red");
    assert_close(linear_rgb_to_xyz(Vec3::Y).y, 0.7152, 1e-4, "Y of green");
    assert_close(linear_rgb_to_xyz(Vec3::Z).y, 0.0722, 1e-4, "Y of blue");
}

#[test]
fn xyz_and_linear_rgb_round_trip() {
    for rgb in [Vec3::new(0.2, 0.5, 0.9), Vec3::new(1.0, 0.0, 0.3), Vec3::splat(0.18)] {
        assert_vec_close(xyz_to_linear_rgb(linear_rgb_to_xyz(rgb)), rgb, 1e-5, "RGB→XYZ→RGB");
    }
}

#[test]
fn lab_of_known_colours() {
    assert_vec_close(xyz_to_lab(D65_WHITE), Vec3::new(100.0, 0.0, 0.0), 1e-3, "Lab of white");
    assert_vec_close(xyz_to_lab(Vec3::ZERO), Vec3::ZERO, 1e-3, "Lab of black");
    // Standard CIELab (D65) values of the sRGB primaries.
    let lab = |rgb: Vec3| xyz_to_lab(linear_rgb_to_xyz(rgb));
    assert_vec_close(lab(Vec3::X), Vec3::new(53.24, 80.09, 67.20), 0.05, "Lab of red");
    assert_vec_close(lab(Vec3::Y), Vec3::new(87.73, -86.18, 83.18), 0.05, "Lab of green");
    assert_vec_close(lab(Vec3::Z), Vec3::new(32.30, 79.19, -107.86), 0.05, "Lab of blue");
    // 18% grey is L* ≈ 49.5, achromatic.
    assert_vec_close(lab(Vec3::splat(0.18)), Vec3::new(49.50, 0.0, 0.0), 0.01, "Lab of 18% grey");
}

#[test]
fn ycxcz_round_trips_and_agrees_with_lab_at_white() {
    assert_vec_close(xyz_to_ycxcz(D65_WHITE), Vec3::new(100.0, 0.0, 0.0), 1e-3, "YCxCz of white");
    assert_vec_close(xyz_to_ycxcz(Vec3::ZERO), Vec3::new(-16.0, 0.0, 0.0), 1e-6, "YCxCz of black");
    for xyz in [Vec3::new(0.3, 0.4, 0.5), Vec3::new(0.9, 0.1, 0.05), D65_WHITE] {
        assert_vec_close(ycxcz_to_xyz(xyz_to_ycxcz(xyz)), xyz, 1e-5, "XYZ→YCxCz→XYZ");
    }
    assert_vec_close(srgb_to_ycxcz(Vec3::ONE), Vec3::new(100.0, 0.0, 0.0), 1e-3, "sRGB white → YCxCz");
}

#[test]
fn hunt_adjustment_scales_chroma_by_lightness() {
    assert_eq!(hunt_adjust(Vec3::new(50.0, 20.0, -40.0)), Vec3::new(50.0, 10.0, -20.0));
    assert_eq!(hunt_adjust(Vec3::new(100.0, 20.0, -40.0)), Vec3::new(100.0, 20.0, -40.0));
    assert_eq!(hunt_adjust(Vec3::new(0.0, 20.0, -40.0)), Vec3::ZERO);
}

#[test]
fn hyab_is_city_block_in_l_plus_euclidean_in_ab() {
    let a = Vec3::new(60.0, 10.0, 10.0);
    let b = Vec3::new(50.0, 13.0, 14.0);
    assert_close(hyab(a, b), 10.0 + 5.0, 1e-5, "HyAB");
    assert_eq!(hyab(a, b), hyab(b, a));
    assert_eq!(hyab(a, a), 0.0);
}

#[test]
fn cmax_is_compressed_green_blue_distance() {
    // Hunt-adjusted Lab of green (87.73, −75.61, 72.97) and blue
    // (32.30, 25.58, −34.84): HyAB ≈ 55.43 + 147.8 ≈ 203.3, and 203.3^0.7 ≈ 41.3.
    let cmax = max_color_distance();
    assert_close(cmax.powf(1.0 / QC), 203.3, 0.2, "HyAB(green, blue)");
    assert_close(cmax, 203.3f32.powf(0.7), 0.05, "cmax");
}

#[test]
fn redistribution_maps_breakpoints_and_is_monotone() {
    let cmax = max_color_distance();
    assert_eq!(redistribute_color_error(0.0, cmax), 0.0);
    assert_close(redistribute_color_error(PC * cmax, cmax), PT, 1e-6, "at pc·cmax");
    assert_close(redistribute_color_error(cmax, cmax), 1.0, 1e-6, "at cmax");
    assert_close(redistribute_color_error(0.5 * PC * cmax, cmax), 0.5 * PT, 1e-6, "halfway below knee");
    let mut last = -1.0;
    for i in 0..=100 {
        let e = redistribute_color_error(cmax * i as f32 / 100.0, cmax);
        assert!(e > last, "not increasing at step {i}: {e} <= {last}");
        last = e;
    }
}

#[test]
fn feature_error_and_combination() {
    assert_eq!(feature_error([0.3, 0.2], [0.3, 0.2]), 0.0);
    // Larger of the two differences, scaled by 1/√2, square-rooted.
    assert_close(feature_error([0.5, 0.1], [0.1, 0.2]), (0.4f32 / 2f32.sqrt()).sqrt(), 1e-6, "edge dominates");
    assert_close(feature_error([0.0, 2f32.sqrt()], [0.0, 0.0]), 1.0, 1e-6, "maximal difference");
    assert_eq!(combine_errors(0.25, 0.0), 0.25);
    assert_close(combine_errors(0.25, 0.5), 0.5, 1e-6, "0.25^0.5");
    assert_eq!(combine_errors(0.25, 1.0), 1.0);
    assert_eq!(combine_errors(0.0, 0.5), 0.0);
}

#[test]
fn csf_filters_are_normalised_and_sized() {
    let ppd = ppd_default();
    let f = spatial_filters(ppd);
    let r = spatial_filter_radius(ppd);
    // ceil(3·√(0.04 / 2π²)·67.02) = ceil(9.05).
    assert_eq!(r, 10);
    for k in [&f.achromatic, &f.red_green, &f.blue_yellow[0], &f.blue_yellow[1]] {
        assert_eq!(k.len(), 2 * r + 1);
        assert!(k.iter().zip(k.iter().rev()).all(|(a, b)| a == b), "CSF factor not symmetric");
    }
    let sum = |k: &[f32]| k.iter().sum::<f32>();
    assert_close(sum(&f.achromatic), 1.0, 1e-5, "achromatic sum");
    assert_close(sum(&f.red_green), 1.0, 1e-5, "red-green sum");
    let by = sum(&f.blue_yellow[0]).powi(2) + sum(&f.blue_yellow[1]).powi(2);
    assert_close(by, 1.0, 1e-5, "2D blue-yellow sum");
}

#[test]
fn separable_csf_equals_the_2d_sum_of_gaussians() {
    // The 2D kernel as the paper and the reference's Python code define it.
    let ppd = 40.0;
    let f = spatial_filters(ppd);
    let r = spatial_filter_radius(ppd) as i32;
    let channels: [(CsfParams, Vec<&[f32]>); 3] = [
        (CSF_ACHROMATIC, vec![&f.achromatic]),
        (CSF_RED_GREEN, vec![&f.red_green]),
        (CSF_BLUE_YELLOW, vec![&f.blue_yellow[0], &f.blue_yellow[1]]),
    ];
    for (p, factors) in channels {
        let full = |x: i32, y: i32| {
            let z = ((x * x + y * y) as f64) / f64::from(ppd * ppd);
            let pi = std::f64::consts::PI;
            let g = |a: f32, b: f32| f64::from(a) * (pi / f64::from(b)).sqrt() * (-pi * pi * z / f64::from(b)).exp();
            g(p.a1, p.b1) + g(p.a2, p.b2)
        };
        let total: f64 = (-r..=r).flat_map(|y| (-r..=r).map(move |x| (x, y))).map(|(x, y)| full(x, y)).sum();
        for y in -r..=r {
            for x in -r..=r {
                let expected = (full(x, y) / total) as f32;
                let (i, j) = ((x + r) as usize, (y + r) as usize);
                let got: f32 = factors.iter().map(|k| k[i] * k[j]).sum();
                assert_close(got, expected, 1e-6, &format!("{p:?} at ({x}, {y})"));
            }
        }
    }
}

#[test]
fn feature_filters_are_normalised_and_sized() {
    let ppd = ppd_default();
    let f = feature_filters(ppd);
    // σ = 0.5·0.082·67.02 ≈ 2.748 px, radius ceil(3σ) = 9.
    assert_close(feature_filter_std_dev(ppd), 2.7478, 1e-3, "σ");
    assert_eq!(feature_filter_radius(ppd), 9);
    let n = 2 * 9 + 1;
    assert!(f.gaussian.len() == n && f.edge.len() == n && f.point.len() == n);
    let sum = |k: &[f32]| k.iter().sum::<f32>();
    let pos = |k: &[f32]| k.iter().filter(|&&w| w > 0.0).sum::<f32>();
    assert_close(sum(&f.gaussian), 1.0, 1e-6, "gaussian sum");
    assert_close(sum(&f.edge), 0.0, 1e-6, "edge sum");
    assert_close(sum(&f.point), 0.0, 1e-6, "point sum");
    assert_close(pos(&f.edge), 1.0, 1e-6, "edge positive mass");
    assert_close(pos(&f.point), 1.0, 1e-6, "point positive mass");
    for i in 0..n {
        // Up to rounding: each sign is divided by its own (float) sum.
        assert_close(f.edge[i], -f.edge[n - 1 - i], 1e-7, "edge filter odd");
        assert_close(f.point[i], f.point[n - 1 - i], 1e-7, "point filter even");
    }
    // Negated derivative, as in the reference: positive taps on the left.
    assert!(f.edge[0] > 0.0 && f.edge[n - 1] < 0.0);
    // Second derivative is negative at the centre.
    assert!(f.point[9] < 0.0);
}

#[test]
fn csf_filter_preserves_uniform_images_and_clamps_borders() {
    let (w, h) = (7, 5);
    let img = vec![Vec3::new(40.0, -12.0, 30.0); w * h];
    let f = spatial_filters(ppd_default());
    // Kernel (21 taps) wider than the image: only clamp-to-edge keeps it uniform.
    for p in csf_filter(&img, w, h, &f) {
        assert_vec_close(p, Vec3::new(40.0, -12.0, 30.0), 1e-3, "filtered uniform image");
    }
    let mags = feature_magnitudes(&img, w, h, &feature_filters(ppd_default()));
    assert!(mags.iter().all(|m| m[0].abs() < 1e-6 && m[1].abs() < 1e-6), "features in a uniform image");
}

#[test]
fn edge_detector_responds_to_a_step_and_point_detector_to_a_dot() {
    let (w, h) = (41, 41);
    let ppd = ppd_default();
    let f = feature_filters(ppd);
    let step: Vec<Vec3> = (0..w * h).map(|i| Vec3::new(if i % w < w / 2 { -16.0 } else { 100.0 }, 0.0, 0.0)).collect();
    let m = feature_magnitudes(&step, w, h, &f);
    let at = |x: usize, y: usize| m[y * w + x];
    // A unit step (normalised Y 0 → 1) gives an edge response near the
    // positive mass of the edge filter, 1, straddling the step.
    assert!(at(w / 2, h / 2)[0] > 0.3, "edge at step: {:?}", at(w / 2, h / 2));
    assert!(at(2, h / 2)[0] < 1e-6, "edge far from step: {:?}", at(2, h / 2));
    let mut dot = vec![Vec3::new(-16.0, 0.0, 0.0); w * h];
    dot[(h / 2) * w + w / 2] = Vec3::new(100.0, 0.0, 0.0);
    let m = feature_magnitudes(&dot, w, h, &f);
    assert!(m[(h / 2) * w + w / 2][1] > m[(h / 2) * w + w / 2][0], "point beats edge at a dot");
}

#[test]
fn identical_images_have_exactly_zero_error() {
    for (w, h) in [(23, 17), (1, 1), (3, 40)] {
        let img = noise(w, h, 2);
        let map = flip_error_map(&img, &img, w, h, ppd_default());
        assert!(map.iter().all(|&e| e == 0.0), "nonzero error for identical {w}×{h} images");
        assert_eq!(mean_flip(&img, &img, w, h, ppd_default()), 0.0);
    }
}

#[test]
fn black_versus_white_is_close_to_one() {
    // Uniform images have no features, so this is the colour term alone:
    // HyAB(black, white) = 100, 100^0.7 = 25.12 is above pc·cmax ≈ 16.5, so
    // the error lands in (pt, 1]. The reference (flip-evaluator 1.7 from
    // PyPI) gives 0.967388 at every pixel, either way round.
    let (w, h) = (16, 12);
    let black = uniform(w, h, [0.0; 3]);
    let white = uniform(w, h, [1.0; 3]);
    for map in
        [flip_error_map(&black, &white, w, h, ppd_default()), flip_error_map(&white, &black, w, h, ppd_default())]
    {
        for e in map {
            assert_close(e, 0.967_388, 2e-5, "black vs white");
        }
    }
    // Zero up to the rounding of the filters' zero sums (amplified by the square root).
    assert!(feature_error_map(&black, &white, w, h, ppd_default()).iter().all(|&f| f < 1e-3));
}

#[test]
fn error_is_symmetric_in_reference_and_test() {
    let (w, h) = (23, 17);
    let (a, b) = (noise(w, h, 0), gradient(w, h, true));
    assert_eq!(flip_error_map(&a, &b, w, h, 30.0), flip_error_map(&b, &a, w, h, 30.0));
}

#[test]
fn error_map_mirrors_and_transposes_with_the_images() {
    let (w, h) = (23, 17);
    let ppd = ppd_default();
    let (a, b) = (noise(w, h, 0), noise(w, h, 1));
    let base = flip_error_map(&a, &b, w, h, ppd);
    let mirrored = flip_error_map(&mirror_x(&a, w), &mirror_x(&b, w), w, h, ppd);
    let transposed = flip_error_map(&transpose(&a, w, h), &transpose(&b, w, h), h, w, ppd);
    // Filters are symmetric, so only summation order differs.
    for (x, y) in mirror_x(&base, w).iter().zip(&mirrored) {
        assert_close(*y, *x, 1e-4, "mirrored map");
    }
    for (x, y) in transpose(&base, w, h).iter().zip(&transposed) {
        assert_close(*y, *x, 1e-4, "transposed map");
    }
}

#[test]
fn error_grows_with_a_growing_offset() {
    let (w, h) = (32, 24);
    let ppd = ppd_default();
    // Mid-range texture, so that offsets up to 0.3 stay inside [0, 1].
    let reference: Vec<[f32; 3]> = noise(w, h, 1).iter().map(|c| c.map(|v| 0.3 + 0.4 * v)).collect();
    let mut last = 0.0;
    for step in 1..=6 {
        let offset = 0.05 * step as f32;
        let test: Vec<[f32; 3]> = reference.iter().map(|c| c.map(|v| v + offset)).collect();
        let mean = mean_flip(&reference, &test, w, h, ppd);
        assert!(mean > last, "mean FLIP did not grow at offset {offset}: {mean} <= {last}");
        last = mean;
    }
    // Same for a flat grey image, pixel by pixel.
    let grey = uniform(4, 4, [0.2; 3]);
    let mut last = 0.0;
    for step in 1..=8 {
        let test = uniform(4, 4, [0.2 + 0.1 * step as f32; 3]);
        let e = flip_error_map(&grey, &test, 4, 4, ppd)[5];
        assert!(e > last, "error did not grow at step {step}: {e} <= {last}");
        last = e;
    }
}

#[test]
fn errors_stay_in_unit_interval() {
    let (w, h) = (23, 17);
    for (a, b) in [(noise(w, h, 0), noise(w, h, 3)), (noise(w, h, 1), gradient(w, h, true))] {
        for ppd in [5.0, 20.0, ppd_default()] {
            assert!(flip_error_map(&a, &b, w, h, ppd).iter().all(|e| (0.0..=1.0).contains(e)));
        }
    }
}

/// Per-pixel values and means computed by NVIDIA's own implementation
/// (`flip_evaluator.evaluate(ref, test, "LDR")` from the `flip-evaluator`
/// 1.7 package on PyPI, i.e. the C++ code of NVlabs/flip) on the same
/// integer-built images. They are not published values: NVlabs/flip
/// publishes a mean of 0.159691 only for its own example PNGs.
#[test]
fn matches_reference_implementation_on_synthetic_images() {
    type Case = (&'static str, usize, usize, Vec<[f32; 3]>, Vec<[f32; 3]>, Option<f32>, f32, [(usize, usize, f32); 7]);
    let cases: [Case; 4] = [
        (
            "noise 23×17",
            23,
            17,
            noise(23, 17, 0),
            noise(23, 17, 1),
            None,
            0.263_065_6,
            [
                (0, 0, 0.100_499_6),
                (22, 0, 0.273_201_3),
                (0, 16, 0.561_724_1),
                (22, 16, 0.235_834_4),
                (11, 8, 0.443_351_5),
                (7, 8, 0.224_048_1),
                (11, 1, 0.146_315),
            ],
        ),
        (
            "noise 23×17, 20 ppd",
            23,
            17,
            noise(23, 17, 0),
            noise(23, 17, 1),
            Some(20.0),
            0.348_601_2,
            [
                (0, 0, 0.065_015_1),
                (22, 0, 0.092_819_9),
                (0, 16, 0.329_406_7),
                (22, 16, 0.259_369_3),
                (11, 8, 0.983_664_9),
                (7, 8, 0.491_344_8),
                (11, 1, 0.819_814_5),
            ],
        ),
        (
            "gradient with square 40×30",
            40,
            30,
            gradient(40, 30, false),
            gradient(40, 30, true),
            None,
            0.168_578_7,
            [
                (0, 0, 0.0),
                (39, 0, 0.0),
                (0, 29, 0.0),
                (39, 29, 0.0),
                (20, 15, 0.864_608_2),
                (13, 15, 0.801_864),
                (20, 1, 0.004_344),
            ],
        ),
        (
            "noise 4×3 (smaller than the filters)",
            4,
            3,
            noise(4, 3, 0),
            noise(4, 3, 1),
            None,
            0.323_910_8,
            [
                (0, 0, 0.114_761_5),
                (3, 0, 0.278_595_6),
                (0, 2, 0.383_074_7),
                (3, 2, 0.313_302_7),
                (2, 1, 0.375_435_6),
                (1, 1, 0.295_914_9),
                (2, 1, 0.375_435_6),
            ],
        ),
    ];
    for (name, w, h, reference, test, ppd, mean, pixels) in cases {
        let ppd = ppd.unwrap_or_else(ppd_default);
        let map = flip_error_map(&reference, &test, w, h, ppd);
        for (x, y, expected) in pixels {
            assert_close(map[y * w + x], expected, 2e-5, &format!("{name} at ({x}, {y})"));
        }
        assert_close(mean_flip(&reference, &test, w, h, ppd), mean, 2e-6, &format!("{name} mean"));
    }
}

#[test]
#[should_panic(expected = "expected 4×4")]
fn mismatched_dimensions_panic() {
    flip_error_map(&uniform(4, 4, [0.0; 3]), &uniform(4, 3, [0.0; 3]), 4, 4, 67.0);
}
