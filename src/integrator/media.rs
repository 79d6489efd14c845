//! The refracting volumes a path is inside, as an interface stack: which index of
//! refraction lies on each side of an interface, and what absorbs along each segment.
//! Crossing a volume's surface from its front pushes the volume, from its back removes it,
//! so a liquid inside a glass sees the glass (not air) around it. A camera inside volumes
//! starts with the stack a probe ray finds (`Media::containing`). And where along a segment
//! a scattering volume scatters a path (`flight`).

use crate::math::sampler::Sampler;
pub use crate::medium::transmittance;
use crate::medium::{Flight, Volume, sample_flight};
use crate::scene::{Scene, geometry::Ray, material::Material};
use crate::spectrum::{Spectrum, Wavelengths};
use glam::Vec3;

/// Most surfaces a probe ray looks at.
const PROBE_HITS: usize = 1024;

/// Deepest nesting tracked; deeper entries are ignored (treated as not entered).
const DEPTH: usize = 8;

/// Materials of the volumes a path is in, innermost last.
#[derive(Clone, Copy, Debug, Default)]
pub struct Media {
    entries: [u32; DEPTH],
    len: usize,
}

impl Media {
    /// Whether the path is in no volume.
    pub fn is_empty(&self) -> bool {
        self.len == 0
    }

    fn find(&self, material: u32) -> Option<usize> {
        self.entries[..self.len].iter().rposition(|&m| m == material)
    }

    /// Index of refraction of the medium around `material`'s volume, at an interface hit
    /// from its front (entering) or its back (leaving).
    pub fn outside_ior(&self, materials: &[Material], material: u32, front: bool) -> f32 {
        let enclosing = match (front, self.find(material)) {
            (false, Some(i)) => i.checked_sub(1).map(|j| self.entries[j]),
            _ => self.entries[..self.len].last().copied(),
        };
        enclosing.map_or(1.0, |m| materials[m as usize].ior)
    }

    /// Records a transmission through `material`'s surface from its front or back.
    pub fn cross(&mut self, material: u32, front: bool) {
        if front {
            if self.len < DEPTH {
                self.entries[self.len] = material;
                self.len += 1;
            }
        } else if let Some(i) = self.find(material) {
            self.entries.copy_within(i + 1..self.len, i);
            self.len -= 1;
        }
    }

    /// The volumes that contain `point`: a probe ray from it meets the back of each volume's
    /// surface once more than its front. Walking out along the probe, the innermost volume
    /// is left first; the stack lists them outermost first.
    pub fn containing(scene: &Scene, point: Vec3) -> Self {
        let mut media = Self::default();
        if !scene.features.volumes {
            return media;
        }
        let d = Vec3::new(0.267, 0.873, 0.408).normalize();
        let mut ray = Ray { o: point, d, tmax: f32::INFINITY };
        let (mut entered, mut inside) = (Vec::new(), Vec::new());
        for _ in 0..PROBE_HITS {
            let Some(hit) = scene.intersect(&ray, true, false) else { break };
            let surface = scene.surface(&hit);
            if scene.materials[surface.material as usize].is_volume() {
                let front = surface.ng.dot(d) < 0.0;
                match (front, entered.iter().rposition(|&m| m == surface.material)) {
                    (true, _) => entered.push(surface.material),
                    (false, Some(i)) => {
                        entered.remove(i);
                    }
                    (false, None) => inside.push(surface.material),
                }
            }
            let front = surface.ng.dot(d) < 0.0;
            ray.o = scene.reflection_origin(&surface, !front, false, true);
        }
        for &m in inside.iter().rev() {
            media.cross(m, true);
        }
        media
    }

    /// The medium of the innermost volume, if any.
    pub fn volume(&self, materials: &[Material]) -> Option<Volume> {
        self.entries[..self.len].last().and_then(|&m| materials[m as usize].volume)
    }

    /// Extinction coefficient of the innermost volume (zero outside every volume).
    pub fn sigma_t(&self, materials: &[Material]) -> Spectrum {
        self.volume(materials).map_or(Spectrum::ZERO, |v| v.sigma_t())
    }
}

/// Where the scattering `volume` scatters a path of throughput `beta` first along `ray`, up
/// to the surface at `t_max` (the ray's unit direction's distance; infinite without one):
/// delta tracking through a density grid (a real collision scatters with the albedo as
/// weight; passing weighs 1), free-flight sampling in a homogeneous medium (pbrt-v4's
/// VolPathIntegrator). The distance is along the ray's unit direction.
#[inline]
pub fn flight(
    scene: &Scene,
    volume: &Volume,
    (ray, t_max): (&Ray, f32),
    beta: Spectrum,
    sampler: &mut Sampler,
    wl: &Wavelengths,
) -> Flight {
    match volume.grid {
        Some(g) => {
            let mut u = || sampler.next_1d();
            let (sigma, length) = (volume.sigma_t.max_element(), ray.d.length());
            match scene.grids[g as usize].delta_track(sigma, ray.o, ray.d / length, t_max, &mut u) {
                Some(t) => Flight::Scatter { t, weight: wl.reflectance(Spectrum::from_rgb(volume.albedo)) },
                None => Flight::Pass { weight: Spectrum::ONE },
            }
        }
        None => {
            let u = (sampler.next_1d(), sampler.next_1d());
            sample_flight(wl.reflectance(volume.sigma_t()), wl.reflectance(volume.sigma_s()), t_max, beta, u)
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use glam::Vec3;

    #[test]
    fn a_probe_finds_the_volumes_around_a_point_outermost_first() {
        use crate::scene::{SceneDesc, shapes::uv_sphere};
        let materials = vec![
            Material::glass("outer", 1.5, Some(Vec3::ZERO)),
            Material::glass("inner", 1.33, Some(Vec3::splat(0.5))),
            Material::glass("beside", 1.2, Some(Vec3::ZERO)),
        ];
        let desc = SceneDesc {
            meshes: vec![
                uv_sphere(Vec3::ZERO, 2.0, 16, 32, false, 0),
                uv_sphere(Vec3::ZERO, 1.0, 16, 32, false, 1),
                uv_sphere(Vec3::new(0.0, 5.0, 0.0), 1.0, 16, 32, false, 2),
            ],
            materials: materials.clone(),
            ..SceneDesc::default()
        };
        let scene = Scene::build(desc);
        let mut m = Media::containing(&scene, Vec3::new(0.1, 0.0, 0.0));
        assert_eq!(m.len, 2);
        assert_eq!(m.sigma_t(&scene.materials), Spectrum::splat(0.5), "innermost: the liquid");
        m.cross(1, false);
        assert_eq!(m.outside_ior(&scene.materials, 0, false), 1.0);
        let between = Media::containing(&scene, Vec3::new(1.5, 0.0, 0.0));
        assert_eq!((between.len, between.entries[0]), (1, 0), "between the shells: only the outer");
        assert_eq!(Media::containing(&scene, Vec3::new(0.0, 0.0, 9.0)).len, 0, "outside everything");
    }

    #[test]
    fn nested_volumes_see_their_enclosing_index() {
        let materials = vec![
            Material::glass("glass", 1.5, Some(Vec3::ZERO)),
            Material::glass("water", 1.33, Some(Vec3::splat(0.5))),
        ];
        let mut m = Media::default();
        assert_eq!(m.outside_ior(&materials, 0, true), 1.0);
        m.cross(0, true);
        assert_eq!(m.outside_ior(&materials, 1, true), 1.5);
        m.cross(1, true);
        assert_eq!(m.sigma_t(&materials), Spectrum::splat(0.5));
        assert_eq!(m.outside_ior(&materials, 1, false), 1.5);
        m.cross(1, false);
        assert_eq!(m.outside_ior(&materials, 0, false), 1.0);
        m.cross(0, false);
        assert_eq!(m.sigma_t(&materials), Spectrum::ZERO);
        // Leaving a volume never entered (a camera inside glass) sees air outside.
        assert_eq!(m.outside_ior(&materials, 0, false), 1.0);
        assert_eq!(
            transmittance(Spectrum::from_rgb(Vec3::new(0.0, 1.0, 2.0)), f32::INFINITY),
            Spectrum::from_rgb(Vec3::new(1.0, 0.0, 0.0))
        );
    }
}
