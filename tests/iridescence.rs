//! KHR_materials_iridescence's thin film (`lucent::bsdf::thin_film`) against the physics
//! computed here independently: the reflectance of one layer by the transfer (characteristic)
//! matrix method with complex amplitudes, per polarisation, averaged; its colour by
//! integrating that spectrum against the CIE 1931 matching functions. Also: a film of
//! thickness 0 is the base's plain Fresnel reflectance, and iridescence 0 is the plain
//! material.

use glam::{Vec2, Vec3};
use lucent::bsdf::microfacet::fresnel_dielectric;
use lucent::bsdf::thin_film::{reflectance, reflectance_rgb, sensitivity};
use lucent::bsdf::{Bsdf, MetalRough, TransportMode};
use lucent::spectrum::Spectrum;
use lucent::spectrum::sampled::cmf;
use lucent::spectrum::upsample::XYZ_TO_RGB;

#[derive(Clone, Copy)]
struct C(f64, f64);

impl C {
    fn add(self, o: C) -> C {
        C(self.0 + o.0, self.1 + o.1)
    }
    fn scale(self, s: f64) -> C {
        C(self.0 * s, self.1 * s)
    }
    fn div(self, o: C) -> C {
        let d = o.0 * o.0 + o.1 * o.1;
        C((self.0 * o.0 + self.1 * o.1) / d, (self.1 * o.0 - self.0 * o.1) / d)
    }
    fn norm2(self) -> f64 {
        self.0 * self.0 + self.1 * self.1
    }
}

/// Reflectance of a film (index n2, thickness d nm) between index 1 and a base of index n3,
/// at cosine `cos1` and wavelength `lambda` nm, by the characteristic matrix of the layer
/// (Born and Wolf, section 1.6): M = [[cos b, -i sin b / Y2], [-i Y2 sin b, cos b]],
/// b = 2 pi n2 d cos2 / lambda, with tilted admittances Y = n cos (s) or n / cos (p);
/// r = (Y1 m11 + Y1 Y3 m12 - m21 - Y3 m22) / (Y1 m11 + Y1 Y3 m12 + m21 + Y3 m22).
fn transfer_matrix(cos1: f64, n2: f64, n3: f64, d: f64, lambda: f64) -> f64 {
    let sin1 = (1.0 - cos1 * cos1).sqrt();
    let cos2 = (1.0 - (sin1 / n2).powi(2)).sqrt();
    let cos3 = (1.0 - (sin1 / n3).powi(2)).sqrt();
    let beta = 2.0 * std::f64::consts::PI * n2 * d * cos2 / lambda;
    let mut sum = 0.0;
    for (y1, y2, y3) in [(cos1, n2 * cos2, n3 * cos3), (1.0 / cos1, n2 / cos2, n3 / cos3)] {
        let (m11, m22) = (C(beta.cos(), 0.0), C(beta.cos(), 0.0));
        let m12 = C(0.0, -beta.sin() / y2);
        let m21 = C(0.0, -y2 * beta.sin());
        let a = m11.scale(y1).add(m12.scale(y1 * y3));
        let b = m21.add(m22.scale(y3));
        let r = a.add(b.scale(-1.0)).div(a.add(b));
        sum += r.norm2();
    }
    0.5 * sum
}

const CASES: [(f32, f32, f32); 5] =
    [(1.3, 1.5, 100.0), (1.3, 1.5, 400.0), (1.8, 1.5, 250.0), (1.3, 3.0, 300.0), (2.0, 1.2, 700.0)];
const COSINES: [f32; 4] = [1.0, 0.8, 0.45, 0.1];

#[test]
fn the_airy_sum_matches_the_transfer_matrix() {
    for (n2, n3, d) in CASES {
        for cos in COSINES {
            for lambda in [400.0f32, 480.0, 550.0, 633.0, 700.0] {
                let airy = reflectance(cos, n2, n3, d, lambda) as f64;
                let exact = transfer_matrix(cos as f64, n2 as f64, n3 as f64, d as f64, lambda as f64);
                // f32 evaluation of a ratio of O(1) terms: a few ulps of 1.
                assert!(
                    (airy - exact).abs() < 2e-5,
                    "n2 {n2}, n3 {n3}, d {d}, cos {cos}, {lambda} nm: {airy} vs {exact}"
                );
            }
        }
    }
}

/// XYZ-to-RGB of the renderer (linear Rec. 709), applied to an XYZ normalised by the
/// integral of y-bar.
fn to_rgb(xyz: [f64; 3]) -> Vec3 {
    let m = XYZ_TO_RGB;
    let row = |i: usize| (m[i][0] as f64 * xyz[0] + m[i][1] as f64 * xyz[1] + m[i][2] as f64 * xyz[2]) as f32;
    Vec3::new(row(0), row(1), row(2))
}

/// XYZ of `f(lambda)` integrated against the matching functions (1 nm steps, 360 to 830 nm)
/// over the integral of y-bar.
fn integrate_xyz(f: impl Fn(f64) -> f64) -> [f64; 3] {
    let (mut xyz, mut y) = ([0.0f64; 3], 0.0f64);
    for l in 360..=830 {
        let c = cmf(l as f32);
        let v = f(l as f64);
        xyz[0] += v * c.x as f64;
        xyz[1] += v * c.y as f64;
        xyz[2] += v * c.z as f64;
        y += c.y as f64;
    }
    xyz.map(|x| x / y)
}

/// Largest |r12 r23| over the two polarisations at cosine `cos1`: the ratio of the film's
/// Fourier series.
fn series_ratio(cos1: f64, n2: f64, n3: f64) -> f64 {
    let sin1 = (1.0 - cos1 * cos1).sqrt();
    let cos2 = (1.0 - (sin1 / n2).powi(2)).sqrt();
    let cos3 = (1.0 - (sin1 / n3).powi(2)).sqrt();
    let s = |a: f64, ca: f64, b: f64, cb: f64| (a * ca - b * cb) / (a * ca + b * cb);
    let p = |a: f64, ca: f64, b: f64, cb: f64| (b * ca - a * cb) / (b * ca + a * cb);
    let qs = (s(1.0, cos1, n2, cos2) * s(n2, cos2, n3, cos3)).abs();
    let qp = (p(1.0, cos1, n2, cos2) * p(n2, cos2, n3, cos3)).abs();
    qs.max(qp)
}

/// The RGB film against the spectrum integrated here. The Fourier method keeps the constant
/// part of the reflectance (its mean over the phase, R0) grey and integrates the oscillating
/// part through a Gaussian fit of the matching functions, so the reference is R0 plus the
/// RGB of the integral of R(lambda) - R0. The tolerance is the method's error bound: term m
/// has amplitude 2 |C_m| <= 2 q^m (q = |r12 r23|, C_m = (Rs - T) q^m with |Rs - T| <= 1)
/// and is off by at most the fit's largest error e over the optical paths involved
/// (measured here against the tabulated matching functions); the terms after the third
/// add at most 2 q^4 / (1 - q) times the largest RGB of a unit cosine (3.3, the largest
/// row sum of |XYZ to RGB|). 1e-4 covers the 1 nm quadrature and f32.
#[test]
fn the_rgb_film_matches_the_integrated_spectrum() {
    let mut worst_fit = 0.0f32;
    for (n2, n3, d) in CASES {
        for cos in COSINES {
            let (c, n2f, n3f, df) = (cos as f64, n2 as f64, n3 as f64, d as f64);
            let got = reflectance_rgb(cos, n2, n3, d);
            let cos2 = (1.0 - (1.0 - c * c) / (n2f * n2f)).sqrt();
            let period = 550.0 / (2.0 * n2f * cos2);
            let steps = 4096;
            let mean = (0..steps)
                .map(|k| transfer_matrix(c, n2f, n3f, 100.0 + period * (k as f64 + 0.5) / steps as f64, 550.0))
                .sum::<f64>()
                / steps as f64;
            let oscillating = integrate_xyz(|l| transfer_matrix(c, n2f, n3f, df, l) - mean);
            let reference = Vec3::splat(mean as f32) + to_rgb(oscillating);
            let opd_max = 3.0 * 2.0 * n2 * d * cos2 as f32;
            let fit_error = (0..=300)
                .flat_map(|i| [0.0f32, std::f32::consts::PI].map(move |shift| (i, shift)))
                .map(|(i, shift)| {
                    let opd = opd_max * i as f32 / 300.0;
                    let phase = |l: f64| (2.0 * std::f64::consts::PI * opd as f64 / l + shift as f64).cos();
                    (sensitivity(opd, shift) - to_rgb(integrate_xyz(phase))).abs().max_element()
                })
                .fold(0.0f32, f32::max);
            worst_fit = worst_fit.max(fit_error);
            let q = series_ratio(c, n2f, n3f) as f32;
            let tolerance = 2.0 * (q + q * q + q * q * q) * fit_error + 2.0 * 3.3 * q.powi(4) / (1.0 - q) + 1e-4;
            assert!(
                (got - reference).abs().max_element() <= tolerance,
                "n2 {n2}, n3 {n3}, d {d}, cos {cos}: {got} vs {reference} (tolerance {tolerance}, fit error {fit_error})"
            );
        }
    }
    println!("largest error of the Gaussian fit: {worst_fit}");
}

#[test]
fn a_film_of_thickness_zero_is_the_plain_fresnel_reflectance() {
    for (n2, n3, _) in CASES {
        for cos in COSINES {
            let plain = fresnel_dielectric(cos, n3);
            assert!((reflectance(cos, n2, n3, 0.0, 550.0) - plain).abs() < 1e-6, "{n2} {n3} {cos}");
            let rgb = reflectance_rgb(cos, n2, n3, 0.0);
            assert!((rgb - Vec3::splat(plain)).abs().max_element() < 1e-6, "{n2} {n3} {cos}: {rgb} vs {plain}");
        }
    }
}

#[test]
fn iridescence_zero_is_the_plain_material_and_a_film_changes_it() {
    let plain = MetalRough {
        base: Spectrum::from_rgb(Vec3::new(0.9, 0.6, 0.3)),
        metallic: 0.5,
        alpha: 0.2,
        ..MetalRough::default()
    };
    let off = MetalRough { iridescence: 0.0, film_ior: 1.8, film_thickness: 320.0, ..plain };
    let on = MetalRough { iridescence: 1.0, ..off };
    let wo = Vec3::new(0.5, 0.1, 0.86).normalize();
    let mut changed = 0.0f32;
    for (i, u) in [Vec2::new(0.1, 0.2), Vec2::new(0.6, 0.7), Vec2::new(0.35, 0.9)].into_iter().enumerate() {
        let wi = lucent::math::warp::cos_hemisphere(u);
        let (a, b) = (Bsdf::MetalRough(plain), Bsdf::MetalRough(off));
        assert_eq!(a.eval_pdf(wo, wi, TransportMode::Radiance), b.eval_pdf(wo, wi, TransportMode::Radiance), "{i}");
        let c = Bsdf::MetalRough(on).eval(wo, wi, TransportMode::Radiance);
        changed = changed.max((c.to_rgb() - a.eval(wo, wi, TransportMode::Radiance).to_rgb()).abs().max_element());
    }
    assert!(changed > 1e-3, "a film changes the reflection: {changed}");
}

#[test]
fn at_the_spectral_kernels_wavelength_the_film_is_its_exact_reflectance_there() {
    use lucent::spectrum::sampled::basis_at;
    // Smooth, so the one mirror direction carries the film; a black base, so nothing else.
    let dielectric = MetalRough {
        base: Spectrum::ZERO,
        alpha: 0.0,
        iridescence: 1.0,
        film_ior: 1.3,
        film_thickness: 400.0,
        ..MetalRough::default()
    };
    let gold = Vec3::new(1.0, 0.78, 0.34);
    let metal = MetalRough { base: Spectrum::from_rgb(gold), metallic: 1.0, ..dielectric };
    let mut values = Vec::new();
    for (material, f0) in [(dielectric, Vec3::splat(0.04)), (metal, gold)] {
        for lambda in [420.0f32, 510.0, 580.0, 660.0] {
            for cos in [1.0f32, 0.7, 0.3] {
                let wo = Vec3::new((1.0 - cos * cos).sqrt(), 0.0, cos);
                let at = MetalRough { film_wavelength: Some(lambda), ..material };
                let s = Bsdf::MetalRough(at).sample(wo, 0.0, Vec2::splat(0.5), TransportMode::Radiance).unwrap();
                assert!(s.is_specular());
                let base = lucent::bsdf::thin_film::f0_to_ior(basis_at(lambda).dot(f0).clamp(0.0, 1.0));
                let want = reflectance(cos, 1.3, base, 400.0, lambda);
                let got = s.weight.to_rgb();
                assert!(
                    (got - Vec3::splat(want)).abs().max_element() < 1e-5,
                    "{lambda} nm, cos {cos}: {got} against {want}"
                );
                values.push(want);
            }
        }
    }
    // The film's reflectance is not the same at every wavelength (else nothing was tested).
    let (lo, hi) = values.iter().fold((f32::MAX, f32::MIN), |(lo, hi), &v| (lo.min(v), hi.max(v)));
    assert!(hi - lo > 0.1, "{lo} to {hi}");
}
