//! glTF metallic-roughness materials and their evaluation into a BSDF at a surface point.

use super::texture::{ColorSpace, Image, Texture};
use crate::bsdf::{Bsdf, Lambert, MetalRough};
use glam::{Vec2, Vec3, Vec4Swizzles};

/// Smallest GGX alpha: below it the lobe is numerically a mirror (pbrt-v4's "effectively
/// smooth" threshold); roughness 0 is rendered with this alpha.
pub const MIN_ALPHA: f32 = 1e-3;

/// A glTF material as the renderer uses it.
#[derive(Clone, Debug, PartialEq)]
pub struct Material {
    /// Name from the file (or generated).
    pub name: String,
    /// Linear base colour factor (RGB; alpha unused so far).
    pub base_color: Vec3,
    /// sRGB base colour texture.
    pub base_color_tex: Option<u32>,
    /// Metalness factor in [0, 1].
    pub metallic: f32,
    /// Perceptual roughness factor in [0, 1]; GGX alpha = roughness^2.
    pub roughness: f32,
    /// Texture whose B channel scales metalness and G roughness.
    pub metallic_roughness_tex: Option<u32>,
    /// Emitted radiance: emissiveFactor x KHR_materials_emissive_strength, linear, used 1:1.
    pub emissive: Vec3,
    /// sRGB emissive texture, multiplied with `emissive`.
    pub emissive_tex: Option<u32>,
    /// KHR_materials_specular specularFactor (strength of the dielectric layer).
    pub specular: f32,
    /// KHR_materials_specular specularColorFactor (tints F0 of the dielectric layer).
    pub specular_color: Vec3,
    /// Index of refraction of the dielectric layer (KHR_materials_ior; 1.5 by default).
    pub ior: f32,
}

impl Default for Material {
    fn default() -> Self {
        Self {
            name: "default".into(),
            base_color: Vec3::ONE,
            base_color_tex: None,
            metallic: 1.0,
            roughness: 1.0,
            metallic_roughness_tex: None,
            emissive: Vec3::ZERO,
            emissive_tex: None,
            specular: 1.0,
            specular_color: Vec3::ONE,
            ior: 1.5,
        }
    }
}

impl Material {
    /// A purely Lambertian material (no specular layer) of the given albedo.
    pub fn lambert(name: &str, albedo: Vec3) -> Self {
        Self { name: name.into(), base_color: albedo, metallic: 0.0, specular: 0.0, ..Self::default() }
    }

    /// Whether the BRDF has a GGX lobe (metal, or a dielectric layer with non-zero strength).
    pub fn is_glossy(&self) -> bool {
        self.metallic > 0.0 || self.specular > 0.0
    }

    /// Whether the material emits light.
    pub fn is_emissive(&self) -> bool {
        self.emissive.max_element() > 0.0
    }

    /// Whether any of its slots reads a texture.
    pub fn is_textured(&self) -> bool {
        self.base_color_tex.is_some() || self.metallic_roughness_tex.is_some() || self.emissive_tex.is_some()
    }

    /// The BSDF at texture coordinate `uv`. `TEXTURES` and `GLOSSY` are the scene's feature
    /// switches: when off, texture lookups and the GGX lobe are compiled out.
    pub fn bsdf<const TEXTURES: bool, const GLOSSY: bool>(
        &self,
        textures: &[Texture],
        images: &[Image],
        uv: Vec2,
    ) -> Bsdf {
        let mut base = self.base_color;
        let (mut metallic, mut roughness) = (self.metallic, self.roughness);
        if TEXTURES {
            if let Some(t) = self.base_color_tex {
                base *= textures[t as usize].sample(images, uv, ColorSpace::Srgb).xyz();
            }
            if let Some(t) = self.metallic_roughness_tex {
                let mr = textures[t as usize].sample(images, uv, ColorSpace::Linear);
                roughness *= mr.y;
                metallic *= mr.z;
            }
        }
        if !(GLOSSY && self.is_glossy()) {
            return Bsdf::Lambert(Lambert { albedo: base });
        }
        let f0 = ((self.ior - 1.0) / (self.ior + 1.0)).powi(2);
        Bsdf::MetalRough(MetalRough {
            base,
            metallic: metallic.clamp(0.0, 1.0),
            alpha: (roughness * roughness).clamp(MIN_ALPHA, 1.0),
            dielectric_f0: (f0 * self.specular_color).min(Vec3::ONE),
            specular: self.specular,
        })
    }

    /// Emitted radiance at `uv` (the same from every direction on the front side).
    pub fn emission<const TEXTURES: bool>(&self, textures: &[Texture], images: &[Image], uv: Vec2) -> Vec3 {
        match self.emissive_tex {
            Some(t) if TEXTURES => self.emissive * textures[t as usize].sample(images, uv, ColorSpace::Srgb).xyz(),
            _ => self.emissive,
        }
    }
}
