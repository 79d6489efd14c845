//! Computes the RGB-to-spectrum basis of `src/spectrum/upsample.rs` and prints that file:
//! `cargo run --release --example spectral_basis > src/spectrum/upsample.rs`.
//!
//! Following Mallett and Yuksel (2019, "Spectral Primary Decomposition for Rendering with sRGB
//! Reflectance"), a linear sRGB colour c becomes the spectrum c_r B_r + c_g B_g + c_b B_b of
//! three basis spectra that are non-negative and sum to 1 at every wavelength, and whose
//! colours under D65 are the three primaries. Then every colour in [0, 1]^3 becomes a
//! reflectance in [0, 1] whose colour is exactly c, white becomes exactly 1, and the map
//! is linear, so it also serves emission and coefficients. The basis is found here by
//! minimising the primaries' colour error and the spectra's roughness over softmax
//! weights at 5 nm knots (which keeps them positive and summing to 1), then the small
//! remaining colour error is removed exactly by the inverse of the primaries' 3x3 matrix.

use glam::{DMat3, DVec3};
use lucent::spectrum::cie::{CMF, D65};

const KNOTS: usize = 95;

/// Weight of 1 nm sample `l` (0..=470) in a trapezoid integral over 360 to 830 nm.
fn weight(l: usize) -> f64 {
    if l == 0 || l == 470 { 0.5 } else { 1.0 }
}

fn d65_at(l: usize) -> f64 {
    let (k, t) = (l / 5, (l % 5) as f64 / 5.0);
    if k + 1 >= KNOTS { D65[KNOTS - 1] as f64 } else { D65[k] as f64 * (1.0 - t) + D65[k + 1] as f64 * t }
}

/// Hat function of knot `k` at 1 nm sample `l`.
fn hat(k: usize, l: usize) -> f64 {
    (1.0 - (l as f64 / 5.0 - k as f64).abs()).max(0.0)
}

fn cmf(l: usize) -> DVec3 {
    DVec3::new(CMF[l][0] as f64, CMF[l][1] as f64, CMF[l][2] as f64)
}

fn main() {
    let cmf_y: f64 = (0..=470).map(|l| weight(l) * cmf(l).y).sum();
    let d65_y: f64 = (0..=470).map(|l| weight(l) * d65_at(l) * cmf(l).y).sum::<f64>() / cmf_y;
    let white: DVec3 = (0..=470).map(|l| cmf(l) * (weight(l) * d65_at(l) / d65_y)).sum::<DVec3>() / cmf_y;
    // sRGB primaries (ITU-R BT.709) scaled so that they add up to this white.
    let xyz = |x: f64, y: f64| DVec3::new(x / y, 1.0, (1.0 - x - y) / y);
    let primaries = DMat3::from_cols(xyz(0.64, 0.33), xyz(0.30, 0.60), xyz(0.15, 0.06));
    let s = primaries.inverse() * white;
    let rgb_to_xyz = DMat3::from_cols(primaries.x_axis * s.x, primaries.y_axis * s.y, primaries.z_axis * s.z);
    let xyz_to_rgb = rgb_to_xyz.inverse();
    // w[k]: the linear sRGB that knot k's hat function contributes under D65.
    let w: Vec<DVec3> = (0..KNOTS)
        .map(|k| {
            (0..=470).map(|l| xyz_to_rgb * cmf(l) * (weight(l) * hat(k, l) * d65_at(l) / d65_y)).sum::<DVec3>() / cmf_y
        })
        .collect();
    let softmax = |a: &[DVec3]| -> Vec<DVec3> {
        a.iter()
            .map(|v| {
                let e = (*v - DVec3::splat(v.max_element())).exp();
                e / e.element_sum()
            })
            .collect()
    };
    let project = |b: &[DVec3]| -> DMat3 {
        // Column i: the colour of basis spectrum i.
        let mut p = DMat3::ZERO;
        for k in 0..KNOTS {
            p.x_axis += w[k] * b[k].x;
            p.y_axis += w[k] * b[k].y;
            p.z_axis += w[k] * b[k].z;
        }
        p
    };
    // Start from blue, green and red bands; Adam on the softmax logits.
    let mut a: Vec<DVec3> = (0..KNOTS)
        .map(|k| {
            let l = 360.0 + 5.0 * k as f64;
            DVec3::new(-((l - 610.0) / 60.0).powi(2), -((l - 540.0) / 50.0).powi(2), -((l - 450.0) / 50.0).powi(2))
        })
        .collect();
    let (mut m, mut v) = (vec![DVec3::ZERO; KNOTS], vec![DVec3::ZERO; KNOTS]);
    let (alpha, mu, rate) = (1.0e3, 1.0e-3, 0.02);
    for step in 1..=200_000 {
        let b = softmax(&a);
        let r = project(&b) - DMat3::IDENTITY;
        for k in 0..KNOTS {
            let mut g = DVec3::new(r.x_axis.dot(w[k]), r.y_axis.dot(w[k]), r.z_axis.dot(w[k])) * (2.0 * alpha);
            if k > 0 {
                g += (b[k] - b[k - 1]) * (2.0 * mu);
            }
            if k + 1 < KNOTS {
                g -= (b[k + 1] - b[k]) * (2.0 * mu);
            }
            let ga = b[k] * (g - DVec3::splat(g.dot(b[k])));
            m[k] = m[k] * 0.9 + ga * 0.1;
            v[k] = v[k] * 0.999 + ga * ga * 0.001;
            let mh = m[k] / (1.0 - 0.9f64.powi(step));
            let vh = v[k] / (1.0 - 0.999f64.powi(step.min(100_000)));
            a[k] -= mh * rate / (vh.powf(0.5) + DVec3::splat(1e-12));
        }
    }
    let b = softmax(&a);
    let p = project(&b);
    let k_inv = p.inverse();
    let basis: Vec<DVec3> = b.iter().map(|bk| k_inv.transpose() * *bk).collect();
    let residual = (project(&basis) - DMat3::IDENTITY).to_cols_array().iter().fold(0.0f64, |m, x| m.max(x.abs()));
    let min = basis.iter().fold(f64::MAX, |m, v| m.min(v.min_element()));
    println!("//! Linear sRGB to spectrum (Mallett and Yuksel 2019): a colour c becomes the spectrum");
    println!("//! c . B(lambda) of three basis spectra, non-negative and summing to 1, whose colours under");
    println!("//! D65 are the sRGB primaries. Written by `cargo run --release --example spectral_basis`");
    println!("//! (see there for how); do not edit. Primaries' colour error before the exact");
    println!("//! correction {:.1e}, after {residual:.1e}; smallest basis value {min:.1e}.", {
        (p - DMat3::IDENTITY).to_cols_array().iter().fold(0.0f64, |m, x| m.max(x.abs()))
    });
    println!();
    println!("/// Integral of y-bar over 360 to 830 nm (1 nm trapezoid), nm.");
    println!("pub const CMF_Y: f32 = {};", cmf_y as f32);
    println!("/// Luminance of the tabulated D65 (integral of D65 y-bar over that of y-bar).");
    println!("pub const D65_Y: f32 = {};", d65_y as f32);
    println!("/// CIE XYZ to linear sRGB for the D65 white of these tables (rows).");
    println!("pub const XYZ_TO_RGB: [[f32; 3]; 3] = [");
    let t = xyz_to_rgb.transpose();
    for row in [t.x_axis, t.y_axis, t.z_axis] {
        println!("    [{}, {}, {}],", row.x as f32, row.y as f32, row.z as f32);
    }
    println!("];");
    println!("/// B_r, B_g, B_b at 360, 365, ..., 830 nm.");
    println!("#[rustfmt::skip]");
    println!("pub const BASIS: [[f32; 3]; {KNOTS}] = [");
    for bk in &basis {
        println!("    [{}, {}, {}],", bk.x as f32, bk.y as f32, bk.z as f32);
    }
    println!("];");
}
