//! The environment light, from infinitely far away: an equirectangular HDR map (.hdr or
//! .exr, or the built-in sky) with intensity and rotation, or a uniform background colour.
//! Map directions are importance-sampled by a 2D piecewise-constant density over the
//! texels, in proportion to radiance x sin(theta).

use super::{Disc, LightLeSample, LightSample, LightTarget};
use crate::math::{distribution::Distribution2D, luminance, warp, wrap_index};
use crate::scene::geometry::Ray;
use crate::scene::rgbe::Texels;
use crate::spectrum::Spectrum;
use glam::{Vec2, Vec3};
use serde::{Deserialize, Serialize};
use std::f32::consts::{PI, TAU};
use std::path::{Path, PathBuf};
use std::sync::Arc;

/// What lights the scene from outside: a map, or a uniform colour, scaled and rotated.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default)]
pub struct EnvSettings {
    /// Equirectangular .hdr or .exr map (+y up, the map's centre seen along -z), or
    /// [`BUILT_IN`] for the embedded sky; None for the uniform background.
    pub map: Option<PathBuf>,
    /// Uniform background radiance (linear RGB), used without a map.
    pub background: Vec3,
    /// Scale on the radiance.
    pub intensity: f32,
    /// Rotation of the map about +y, in degrees.
    pub rotation: f32,
}

impl Default for EnvSettings {
    fn default() -> Self {
        Self { map: None, background: Vec3::ZERO, intensity: 1.0, rotation: 0.0 }
    }
}

impl EnvSettings {
    /// Checks the values; the message is one line.
    pub fn validate(&self) -> Result<(), String> {
        if !(self.intensity >= 0.0 && self.intensity.is_finite()) {
            return Err(format!("environment intensity {} must be a finite number >= 0", self.intensity));
        }
        if !self.rotation.is_finite() {
            return Err("environment rotation must be finite".into());
        }
        if !(self.background.is_finite() && self.background.min_element() >= 0.0) {
            return Err(format!("background {} must be finite and >= 0", self.background));
        }
        Ok(())
    }

    /// The built-in sky at its own intensity, unrotated.
    pub fn built_in() -> Self {
        Self { map: Some(BUILT_IN.into()), ..Self::default() }
    }

    /// Whether this lights nothing (no map, black background, or zero intensity).
    pub fn is_black(&self) -> bool {
        self.intensity == 0.0 || (self.map.is_none() && self.background == Vec3::ZERO)
    }
}

/// The map name that selects the sky embedded in the binary instead of a file.
pub const BUILT_IN: &str = "built-in";

/// The built-in sky: Poly Haven's venice_sunset, 1024 x 512 (CC0; see assets/README.md).
const BUILT_IN_HDR: &[u8] = include_bytes!("../../../assets/venice_sunset_1k.hdr");

/// A loaded equirectangular map with its sampling density.
pub struct EnvMap {
    width: usize,
    height: usize,
    texels: Texels,
    distribution: Distribution2D,
    /// Mean luminance over the sphere (per steradian), for light selection by power.
    mean_luminance: f32,
}

impl EnvMap {
    /// Reads an equirectangular .hdr or .exr file, or the built-in sky if `path` is
    /// [`BUILT_IN`]; the error is one line.
    pub fn load(path: &Path) -> Result<Self, String> {
        let fail = |e: &dyn std::fmt::Display| format!("cannot load environment {}: {e}", path.display());
        let image = if path == Path::new(BUILT_IN) {
            image::load_from_memory_with_format(BUILT_IN_HDR, image::ImageFormat::Hdr)
        } else {
            // A FIFO would block the read forever and a device never ends: regular files only.
            crate::memory::regular_file_size(path, crate::memory::Limits::from_machine().memory)
                .map_err(|e| fail(&e))?;
            crate::guard::decode("the image decoder", || image::open(path)).map_err(|e| fail(&e))?
        };
        let image = image.map_err(|e| fail(&image_error(path, e)))?.into_rgb32f();
        let (width, height) = (image.width() as usize, image.height() as usize);
        if width < 2 || height < 1 {
            return Err(fail(&"the map needs at least 2x1 texels"));
        }
        let texels = image.pixels().map(|p| Vec3::from(p.0)).collect();
        Ok(Self::new(width, height, texels))
    }

    /// A map from linear RGB texels, row-major from the top (+y) row; negative and
    /// non-finite values become 0.
    pub fn new(width: usize, height: usize, mut texels: Vec<Vec3>) -> Self {
        for t in &mut texels {
            *t = if t.is_finite() { t.max(Vec3::ZERO) } else { Vec3::ZERO };
        }
        // Radiance is bilinear, so a texel's cell sees its 3x3 neighbours: the density takes
        // their largest luminance, and is never 0 where the radiance is not.
        let lum: Vec<f32> = texels.iter().map(|&t| luminance(t)).collect();
        let mut func = vec![0.0f32; width * height];
        let mut total = 0.0f64;
        for y in 0..height {
            let sin_theta = (PI * (y as f32 + 0.5) / height as f32).sin();
            for x in 0..width {
                let mut m = 0.0f32;
                for dy in [-1i64, 0, 1] {
                    let yy = (y as i64 + dy).clamp(0, height as i64 - 1) as usize;
                    for dx in [width - 1, 0, 1] {
                        m = m.max(lum[yy * width + (x + dx) % width]);
                    }
                }
                func[y * width + x] = m * sin_theta;
                total += (lum[y * width + x] * sin_theta) as f64;
            }
        }
        // Sum over texels of L sin(theta) dtheta dphi, divided by 4 pi.
        let mean_luminance =
            (total * (PI as f64 / height as f64) * (TAU as f64 / width as f64) / (4.0 * PI as f64)) as f32;
        let distribution = Distribution2D::new(&func, width);
        Self { width, height, texels: Texels::new(texels), distribution, mean_luminance }
    }

    fn texel(&self, x: i64, y: i64) -> Vec3 {
        let x = wrap_index(x, self.width as i64) as usize;
        let y = y.clamp(0, self.height as i64 - 1) as usize;
        self.texels.get(y * self.width + x)
    }

    /// Bilinear radiance at map coordinates `uv` in [0, 1)^2 (wrapping in u).
    fn lookup(&self, uv: Vec2) -> Vec3 {
        let p = uv * Vec2::new(self.width as f32, self.height as f32) - 0.5;
        let (x0, y0) = (p.x.floor(), p.y.floor());
        let (fx, fy) = (p.x - x0, p.y - y0);
        let (x0, y0) = (x0 as i64, y0 as i64);
        let top = self.texel(x0, y0) * (1.0 - fx) + self.texel(x0 + 1, y0) * fx;
        let bottom = self.texel(x0, y0 + 1) * (1.0 - fx) + self.texel(x0 + 1, y0 + 1) * fx;
        top * (1.0 - fy) + bottom * fy
    }
}

/// One line for a map that cannot be decoded; one that ends before its texels do is
/// called truncated, with its size and the size its header announces.
fn image_error(path: &Path, e: image::ImageError) -> String {
    match e {
        image::ImageError::IoError(io) if io.kind() == std::io::ErrorKind::UnexpectedEof => {
            let size = std::fs::metadata(path).map_or(0, |m| m.len());
            let header = image::ImageReader::open(path)
                .and_then(|r| r.with_guessed_format())
                .ok()
                .and_then(|r| r.into_dimensions().ok());
            match header {
                Some((w, h)) => format!(
                    "truncated: the file ends after {size} bytes, before the {w}x{h} texels its header announces"
                ),
                None => format!("truncated: the file ends after {size} bytes"),
            }
        }
        e => e.to_string().replace('\n', " "),
    }
}

/// Map coordinates of a direction in the map's frame: u along phi (the centre at -z), v
/// along theta from +y.
fn to_uv(d: Vec3) -> Vec2 {
    let phi = d.x.atan2(-d.z);
    Vec2::new((0.5 + phi / TAU).rem_euclid(1.0), d.y.clamp(-1.0, 1.0).acos() / PI)
}

/// The direction of map coordinates `uv`, and sin(theta).
fn from_uv(uv: Vec2) -> (Vec3, f32) {
    let (phi, theta) = ((uv.x - 0.5) * TAU, uv.y * PI);
    let (sin_t, cos_t) = theta.sin_cos();
    (Vec3::new(sin_t * phi.sin(), cos_t, -sin_t * phi.cos()), sin_t)
}

/// The environment a scene is lit by.
#[derive(Clone)]
pub struct Environment {
    /// What it was made from.
    pub settings: EnvSettings,
    map: Option<Arc<EnvMap>>,
    /// sin and cos of the rotation about +y.
    rotation: (f32, f32),
}

impl Environment {
    /// Loads the map the settings name (if any); the error is one line.
    pub fn load(settings: EnvSettings) -> Result<Self, String> {
        settings.validate()?;
        let map = settings.map.as_deref().map(EnvMap::load).transpose()?;
        Ok(Self::with_map(settings, map.map(Arc::new)))
    }

    /// An environment from settings and an already loaded map (the viewer reuses the map
    /// while intensity and rotation change).
    pub fn with_map(settings: EnvSettings, map: Option<Arc<EnvMap>>) -> Self {
        let rotation = settings.rotation.to_radians().sin_cos();
        Self { settings, map, rotation }
    }

    /// The loaded map, if any.
    pub fn map(&self) -> Option<&Arc<EnvMap>> {
        self.map.as_ref()
    }

    fn to_map(&self, d: Vec3) -> Vec3 {
        let (s, c) = self.rotation;
        Vec3::new(c * d.x - s * d.z, d.y, s * d.x + c * d.z)
    }

    fn to_world(&self, d: Vec3) -> Vec3 {
        let (s, c) = self.rotation;
        Vec3::new(c * d.x + s * d.z, d.y, -s * d.x + c * d.z)
    }

    /// Radiance arriving from unit world direction `d` (travelling along -d).
    pub fn radiance(&self, d: Vec3) -> Spectrum {
        let scale = self.settings.intensity;
        Spectrum::from_illuminant_rgb(match &self.map {
            Some(map) => map.lookup(to_uv(self.to_map(d))) * scale,
            None => self.settings.background * scale,
        })
    }

    /// A direction drawn in proportion to the radiance: (world direction, radiance, solid
    /// angle density); None where the density vanishes (the poles).
    pub fn sample(&self, u: Vec2) -> Option<(Vec3, Spectrum, f32)> {
        let Some(map) = &self.map else {
            let d = warp::uniform_sphere(u);
            return Some((d, self.radiance(d), warp::UNIFORM_SPHERE_PDF));
        };
        let (uv, pdf_uv) = map.distribution.sample(u);
        let (local, sin_theta) = from_uv(uv);
        if pdf_uv <= 0.0 || sin_theta <= 0.0 {
            return None;
        }
        let d = self.to_world(local);
        let radiance = Spectrum::from_illuminant_rgb(map.lookup(uv) * self.settings.intensity);
        Some((d, radiance, pdf_uv / (2.0 * PI * PI * sin_theta)))
    }

    /// `sample` as a light sample, with the probability `pmf` of having chosen the
    /// environment folded into the density; None where it carries no light.
    pub fn sample_li(&self, u: Vec2, pmf: f32) -> Option<LightSample> {
        let (wi, radiance, pdf) = self.sample(u)?;
        if radiance.is_black() {
            return None;
        }
        Some(LightSample { wi, radiance, pdf: pmf * pdf, target: LightTarget::Infinite, is_delta: false })
    }

    /// A ray of the environment's light entering the scene: a direction drawn as `sample`
    /// draws it (`u_dir`), light travelling opposite to it, through a point of `disc`
    /// (`u_pos`).
    pub fn sample_le(&self, disc: Disc, u_pos: Vec2, u_dir: Vec2) -> Option<LightLeSample> {
        let (wi, radiance, pdf_dir) = self.sample(u_dir)?;
        if radiance.is_black() {
            return None;
        }
        let ray = Ray { o: disc.point(-wi, u_pos), d: -wi, tmax: f32::INFINITY };
        Some(LightLeSample { ray, n: None, radiance, pdf_pos: disc.pdf(), pdf_dir })
    }

    /// Solid-angle density with which `sample` returns unit world direction `d`.
    pub fn pdf(&self, d: Vec3) -> f32 {
        let Some(map) = &self.map else { return warp::UNIFORM_SPHERE_PDF };
        let local = self.to_map(d);
        let sin_theta = (1.0 - local.y * local.y).max(0.0).sqrt();
        if sin_theta <= 0.0 {
            return 0.0;
        }
        map.distribution.pdf(to_uv(local)) / (2.0 * PI * PI * sin_theta)
    }

    /// Power reaching a scene of radius `radius` (luminance), for choosing among lights:
    /// pi r^2 times the radiance integrated over the sphere.
    pub fn power(&self, radius: f32) -> f32 {
        let mean = match &self.map {
            Some(map) => map.mean_luminance,
            None => luminance(self.settings.background),
        };
        PI * radius * radius * 4.0 * PI * mean * self.settings.intensity
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn map_coordinates_round_trip_and_rotation_turns_about_y() {
        for uv in [Vec2::new(0.5, 0.5), Vec2::new(0.1, 0.3), Vec2::new(0.9, 0.8)] {
            assert!((to_uv(from_uv(uv).0) - uv).length() < 1e-5);
        }
        assert!((from_uv(Vec2::new(0.5, 0.5)).0 - Vec3::NEG_Z).length() < 1e-6, "the centre is at -z");
        let env = Environment::with_map(EnvSettings { rotation: 90.0, ..EnvSettings::default() }, None);
        let d = Vec3::new(0.3, 0.5, -0.8).normalize();
        assert!((env.to_world(env.to_map(d)) - d).length() < 1e-6);
        assert!((env.to_world(Vec3::NEG_Z) - Vec3::NEG_X).length() < 1e-6, "{}", env.to_world(Vec3::NEG_Z));
    }

    #[test]
    fn the_built_in_sky_keeps_its_texels_in_four_bytes_each_and_bit_for_bit() {
        let map = EnvMap::load(Path::new(BUILT_IN)).expect("the built-in sky");
        let Texels::Rgbe(_) = map.texels else { panic!("the .hdr sky's texels should all be RGBE values") };
        let decoded = image::load_from_memory_with_format(BUILT_IN_HDR, image::ImageFormat::Hdr)
            .expect("the built-in sky")
            .into_rgb32f();
        for (i, p) in decoded.pixels().enumerate() {
            assert_eq!(map.texels.get(i).to_array().map(f32::to_bits), p.0.map(f32::to_bits), "texel {i}");
        }
    }

    #[test]
    fn bilinear_radiance_is_covered_by_the_density() {
        // One bright texel: every direction where the radiance is not zero has a density.
        let (w, h) = (16, 8);
        let mut texels = vec![Vec3::ZERO; w * h];
        texels[3 * w + 5] = Vec3::new(4.0, 2.0, 1.0);
        let env = Environment::with_map(EnvSettings::default(), Some(Arc::new(EnvMap::new(w, h, texels))));
        for i in 0..64 {
            for j in 0..32 {
                let uv = Vec2::new((i as f32 + 0.5) / 64.0, (j as f32 + 0.5) / 32.0);
                let d = from_uv(uv).0;
                if !env.radiance(d).is_black() {
                    assert!(env.pdf(d) > 0.0, "{uv}");
                }
            }
        }
    }
}
