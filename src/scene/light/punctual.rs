//! KHR_lights_punctual lights as a file and the editors hold them (name, colour, intensity,
//! placement, where in the file they came from), and the light each becomes.

use super::Light;
use super::directional::DirectionalLight;
use super::point::PointLight;
use super::spot::{Cone, SpotLight};
use glam::{DMat4, Vec3};

/// The kind of a KHR_lights_punctual light.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum PunctualKind {
    /// Point light: `intensity` is radiant intensity (glTF candela, used 1:1) in all directions.
    Point,
    /// Spot light with the glTF smooth cone falloff between the two angles.
    Spot(Cone),
    /// Directional light: `intensity` is irradiance (glTF lux, used 1:1) on a facing surface.
    Directional,
}

/// Where a punctual light came from in its glTF file, to write edits back.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct LightSource {
    /// Index in the file's KHR_lights_punctual lights.
    pub light: u32,
    /// The node that places it.
    pub node: u32,
    /// From the node's parent's space to the scene's space (the file's world space moved as
    /// the loader centres the scene): a position p in the scene is the local translation
    /// `parent.inverse() * p`.
    pub parent: DMat4,
}

/// A punctual light placed in the world, as described by its file.
#[derive(Clone, Debug, PartialEq)]
pub struct PunctualLight {
    /// Name from the file.
    pub name: String,
    /// What kind of light it is.
    pub kind: PunctualKind,
    /// World position (unused for directional lights).
    pub position: Vec3,
    /// Unit direction the light shines along (the node's -z axis).
    pub direction: Vec3,
    /// Linear RGB colour (glTF color).
    pub color: Vec3,
    /// glTF intensity: candela for point and spot lights, lux for directional ones.
    pub intensity: f32,
    /// KHR_lights_punctual `range` of a point or spot light: the distance at which its
    /// intensity reaches zero (None: infinite, the inverse square alone).
    pub range: Option<f32>,
    /// Where it is in its file (None: not from a file).
    pub source: Option<LightSource>,
}

impl PunctualLight {
    /// Colour times intensity: radiant intensity (or irradiance, for directional lights) per channel.
    pub fn emitted(&self) -> Vec3 {
        self.color * self.intensity
    }

    /// The light this description makes.
    pub fn light(&self) -> Light {
        let (position, range) = (self.position, self.range);
        match self.kind {
            PunctualKind::Point => Light::Point(Box::new(PointLight { position, intensity: self.emitted(), range })),
            PunctualKind::Spot(cone) => Light::Spot(Box::new(SpotLight {
                position,
                direction: self.direction,
                intensity: self.emitted(),
                cone,
                range,
            })),
            PunctualKind::Directional => {
                Light::Directional(Box::new(DirectionalLight { direction: self.direction, irradiance: self.emitted() }))
            }
        }
    }
}

/// The window KHR_lights_punctual recommends for `range`, by which the inverse-square
/// falloff is scaled at squared distance `dist2`: `clamp(1 - (d / range)^4, 0, 1)`
/// (1 without a range).
pub fn range_window(range: Option<f32>, dist2: f32) -> f32 {
    range.map_or(1.0, |r| (1.0 - (dist2 / (r * r)).powi(2)).clamp(0.0, 1.0))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_range_window_is_one_at_the_light_and_zero_from_the_range_on() {
        assert_eq!(range_window(None, 1e6), 1.0);
        let ranged = Some(2.0);
        assert_eq!(range_window(ranged, 0.0), 1.0);
        assert_eq!(range_window(ranged, 1.0), 1.0 - 1.0 / 16.0, "d = range / 2");
        assert_eq!(range_window(ranged, 4.0), 0.0);
        assert_eq!(range_window(ranged, 9.0), 0.0);
    }
}
