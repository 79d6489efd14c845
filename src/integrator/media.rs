//! The refracting volumes a path is inside, as an interface stack: which index of
//! refraction lies on each side of an interface, and what absorbs along each segment.
//! Crossing a volume's surface from its front pushes the volume, from its back removes it,
//! so a liquid inside a glass sees the glass (not air) around it.

use crate::scene::material::Material;
use crate::spectrum::Spectrum;

/// Deepest nesting tracked; deeper entries are ignored (treated as not entered).
const DEPTH: usize = 8;

/// Materials of the volumes a path is in, innermost last.
#[derive(Clone, Copy, Debug, Default)]
pub struct Media {
    entries: [u32; DEPTH],
    len: usize,
}

impl Media {
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

    /// Absorption coefficient of the innermost volume (zero outside every volume).
    pub fn sigma_a(&self, materials: &[Material]) -> Spectrum {
        let sigma = self.entries[..self.len].last().and_then(|&m| materials[m as usize].volume);
        sigma.map_or(Spectrum::ZERO, Spectrum::from_rgb)
    }
}

/// Beer-Lambert transmittance exp(-sigma d), exactly 1 where sigma is 0 (even for d = inf).
pub fn transmittance(sigma: Spectrum, distance: f32) -> Spectrum {
    sigma.map(|s| if s > 0.0 { (-s * distance).exp() } else { 1.0 })
}

#[cfg(test)]
mod tests {
    use super::*;
    use glam::Vec3;

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
        assert_eq!(m.sigma_a(&materials), Spectrum::splat(0.5));
        assert_eq!(m.outside_ior(&materials, 1, false), 1.5);
        m.cross(1, false);
        assert_eq!(m.outside_ior(&materials, 0, false), 1.0);
        m.cross(0, false);
        assert_eq!(m.sigma_a(&materials), Spectrum::ZERO);
        // Leaving a volume never entered (a camera inside glass) sees air outside.
        assert_eq!(m.outside_ior(&materials, 0, false), 1.0);
        assert_eq!(
            transmittance(Spectrum::from_rgb(Vec3::new(0.0, 1.0, 2.0)), f32::INFINITY),
            Spectrum::from_rgb(Vec3::new(1.0, 0.0, 0.0))
        );
    }
}
