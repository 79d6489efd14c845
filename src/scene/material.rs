//! glTF materials (metallic-roughness with the KHR_materials_* extensions) and their
//! evaluation into a BSDF at a surface point.

use super::edit::MATERIAL_PARAMS;
use super::texture::{ColorSpace, Image, Texture};
use super::{Features, Surface};
use crate::bsdf::{Bsdf, Lambert, MetalRough, measured::MerlTable, sheen::MIN_SHEEN_ALPHA};
use crate::math::frame::Frame;
use crate::medium::Volume;
use crate::spectrum::Spectrum;
use glam::{Affine2, Vec2, Vec3, Vec4, Vec4Swizzles};

/// A material slot's texture: which texture, which TEXCOORD set, and the
/// KHR_texture_transform applied to the coordinates.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct TexRef {
    /// Index into the scene's textures.
    pub texture: u32,
    /// TEXCOORD set (0 or 1).
    pub set: u8,
    /// Transform from mesh UVs to texture UVs (identity without the extension).
    pub transform: Affine2,
}

impl TexRef {
    /// A texture read through TEXCOORD_0 without transform.
    pub fn plain(texture: u32) -> Self {
        Self { texture, set: 0, transform: Affine2::IDENTITY }
    }

    /// Filtered lookup at the surface's texture coordinates.
    pub fn sample(&self, textures: &[Texture], images: &[Image], uv: &[Vec2; 2], space: ColorSpace) -> Vec4 {
        let uv = self.transform.transform_point2(uv[(self.set as usize).min(1)]);
        textures[self.texture as usize].sample(images, uv, space)
    }
}

/// What a material reads from its scene to build a BSDF: textures, their images, and the
/// scene's effects (so that a scene without textures or glossy lobes skips their checks).
#[derive(Clone, Copy)]
pub struct SceneRefs<'a> {
    /// The scene's textures.
    pub textures: &'a [Texture],
    /// The images behind them.
    pub images: &'a [Image],
    /// The scene's effects.
    pub features: Features,
}

/// How the base colour's alpha is used (glTF alphaMode).
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum AlphaMode {
    /// Alpha ignored.
    Opaque,
    /// Fully transparent below the cutoff, opaque otherwise.
    Mask(f32),
    /// Partly transparent: a ray passes with probability 1 - alpha.
    Blend,
}

/// KHR_materials_volume and _volume_scatter as the file gives them (clamped into their
/// ranges): what a material's homogeneous medium is made from (`VolumeFactors::medium`).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct VolumeFactors {
    /// thicknessFactor: 0 is a thin wall, anything above it a volume (Lucent traces the
    /// real geometry, so only whether it is positive matters).
    pub thickness: f32,
    /// attenuationColor: the colour white light becomes after `attenuation_distance`, in [0, 1].
    pub attenuation_color: Vec3,
    /// attenuationDistance, positive; infinite (the glTF default) for no attenuation.
    pub attenuation_distance: f32,
    /// KHR_materials_volume_scatter multiscatterColor in [0, 1] (black: no scattering).
    pub multiscatter_color: Vec3,
    /// KHR_materials_volume_scatter scatterAnisotropy, the Henyey-Greenstein g in [-MAX_G, MAX_G].
    pub scatter_anisotropy: f32,
}

impl Default for VolumeFactors {
    fn default() -> Self {
        Self {
            thickness: 0.0,
            attenuation_color: Vec3::ONE,
            attenuation_distance: f32::INFINITY,
            multiscatter_color: Vec3::ZERO,
            scatter_anisotropy: 0.0,
        }
    }
}

impl VolumeFactors {
    /// The medium inside (None for a thin wall): extinction sigma_t = -ln(attenuationColor) /
    /// attenuationDistance, single-scattering albedo from multiscatterColor, g = scatterAnisotropy.
    pub fn medium(&self) -> Option<Volume> {
        if self.thickness.is_nan() || self.thickness <= 0.0 {
            return None;
        }
        let attenuation = self.attenuation_color.max(Vec3::splat(1e-6));
        let distance = self.attenuation_distance;
        let sigma_t =
            if distance.is_finite() && distance > 0.0 { -attenuation.map(f32::ln) / distance } else { Vec3::ZERO };
        // A black multiscatter colour does not scatter (the inversion's 6.2e-6 at 0 would).
        let albedo = match self.multiscatter_color {
            Vec3::ZERO => Vec3::ZERO,
            colour => Volume::single_scatter_albedo(colour),
        };
        Some(Volume { sigma_t, albedo, g: self.scatter_anisotropy, grid: None })
    }
}

/// A glTF material as the renderer uses it.
#[derive(Clone, Debug, PartialEq)]
pub struct Material {
    /// Name from the file (or generated).
    pub name: String,
    /// Its index in the glTF file's materials (None: not from a file's materials, such as
    /// glTF's default material for primitives without one).
    pub file_index: Option<u32>,
    /// Linear base colour factor (RGB).
    pub base_color: Vec3,
    /// Base colour alpha factor.
    pub alpha: f32,
    /// What alpha means.
    pub alpha_mode: AlphaMode,
    /// Whether the back side is visible (glTF doubleSided).
    pub double_sided: bool,
    /// sRGB base colour texture (alpha in A).
    pub base_color_tex: Option<TexRef>,
    /// Metalness factor in [0, 1].
    pub metallic: f32,
    /// Perceptual roughness factor in [0, 1]; GGX alpha = roughness^2.
    pub roughness: f32,
    /// Texture whose B channel scales metalness and G roughness.
    pub metallic_roughness_tex: Option<TexRef>,
    /// Tangent-space normal map.
    pub normal_tex: Option<TexRef>,
    /// Scale of the normal map's X and Y.
    pub normal_scale: f32,
    /// emissiveFactor (linear RGB); the emitted radiance is this times `emissive_strength`
    /// (`Material::emitted`), used 1:1.
    pub emissive: Vec3,
    /// KHR_materials_emissive_strength emissiveStrength (1 without the extension).
    pub emissive_strength: f32,
    /// sRGB emissive texture, multiplied with `emissive`.
    pub emissive_tex: Option<TexRef>,
    /// KHR_materials_specular specularFactor (strength of the dielectric layer).
    pub specular: f32,
    /// Texture whose A channel scales `specular`.
    pub specular_tex: Option<TexRef>,
    /// KHR_materials_specular specularColorFactor (tints F0 of the dielectric layer).
    pub specular_color: Vec3,
    /// sRGB texture scaling `specular_color`.
    pub specular_color_tex: Option<TexRef>,
    /// Index of refraction of the dielectric (KHR_materials_ior; 1.5 by default).
    pub ior: f32,
    /// KHR_materials_dispersion: 20 / V_d, V_d the Abbe number (0: the same index at every
    /// wavelength).
    pub dispersion: f32,
    /// KHR_materials_transmission factor.
    pub transmission: f32,
    /// Texture whose R channel scales `transmission`.
    pub transmission_tex: Option<TexRef>,
    /// The medium inside the surface, None for thin-walled materials: the one
    /// `volume_factors` make (`Material::update_volume`), or a density grid from the media sidecar.
    pub volume: Option<Volume>,
    /// KHR_materials_volume and _volume_scatter as the file gives them.
    pub volume_factors: VolumeFactors,
    /// KHR_materials_clearcoat factor.
    pub clearcoat: f32,
    /// Texture whose R channel scales `clearcoat`.
    pub clearcoat_tex: Option<TexRef>,
    /// Clearcoat perceptual roughness.
    pub clearcoat_roughness: f32,
    /// Texture whose G channel scales `clearcoat_roughness`.
    pub clearcoat_roughness_tex: Option<TexRef>,
    /// The clearcoat's tangent-space normal map (without it, and with a base normal map,
    /// the clearcoat keeps the unmapped normal, as the extension says).
    pub clearcoat_normal_tex: Option<TexRef>,
    /// Scale of the clearcoat normal map's X and Y.
    pub clearcoat_normal_scale: f32,
    /// KHR_materials_anisotropy anisotropyStrength in [0, 1] (0: isotropic).
    pub anisotropy_strength: f32,
    /// anisotropyRotation: radians counter-clockwise from the tangent.
    pub anisotropy_rotation: f32,
    /// Texture whose RG give the direction in [-1, 1] tangent space and B scales the strength.
    pub anisotropy_tex: Option<TexRef>,
    /// KHR_materials_iridescence iridescenceFactor (0: no thin film).
    pub iridescence: f32,
    /// Texture whose R channel scales `iridescence`.
    pub iridescence_tex: Option<TexRef>,
    /// iridescenceIor: index of refraction of the film.
    pub iridescence_ior: f32,
    /// iridescenceThicknessMinimum, nm.
    pub iridescence_thickness_min: f32,
    /// iridescenceThicknessMaximum, nm: the thickness without a thickness texture.
    pub iridescence_thickness_max: f32,
    /// Texture whose G channel chooses the thickness between minimum and maximum.
    pub iridescence_thickness_tex: Option<TexRef>,
    /// KHR_materials_sheen colour (zero: no sheen).
    pub sheen_color: Vec3,
    /// sRGB texture scaling `sheen_color`.
    pub sheen_color_tex: Option<TexRef>,
    /// Sheen perceptual roughness.
    pub sheen_roughness: f32,
    /// Texture whose A channel scales `sheen_roughness`.
    pub sheen_roughness_tex: Option<TexRef>,
    /// KHR_materials_diffuse_transmission factor: share of the diffuse base transmitted.
    pub diffuse_transmission: f32,
    /// Texture whose A channel scales `diffuse_transmission`.
    pub diffuse_transmission_tex: Option<TexRef>,
    /// Colour of the transmitted diffuse light (linear).
    pub diffuse_transmission_color: Vec3,
    /// sRGB texture scaling `diffuse_transmission_color`.
    pub diffuse_transmission_color_tex: Option<TexRef>,
    /// A measured BRDF replacing every lobe above (assigned by a sidecar file).
    pub measured: Option<Measured>,
    /// KHR_materials_unlit: camera rays (and chains of delta bounces from them) see the base
    /// colour; it scatters nothing and lights nothing.
    pub unlit: bool,
}

/// A measured BRDF table and the file it came from, shared by the materials using it.
#[derive(Clone, Debug)]
pub struct Measured {
    /// The MERL .binary file.
    pub path: std::path::PathBuf,
    /// Its samples.
    pub table: std::sync::Arc<MerlTable>,
}

impl PartialEq for Measured {
    fn eq(&self, other: &Self) -> bool {
        std::sync::Arc::ptr_eq(&self.table, &other.table)
    }
}

impl Default for Material {
    fn default() -> Self {
        Self {
            name: "default".into(),
            file_index: None,
            base_color: Vec3::ONE,
            alpha: 1.0,
            alpha_mode: AlphaMode::Opaque,
            double_sided: true,
            base_color_tex: None,
            metallic: 1.0,
            roughness: 1.0,
            metallic_roughness_tex: None,
            normal_tex: None,
            normal_scale: 1.0,
            emissive: Vec3::ZERO,
            emissive_strength: 1.0,
            emissive_tex: None,
            unlit: false,
            specular: 1.0,
            specular_tex: None,
            specular_color: Vec3::ONE,
            specular_color_tex: None,
            ior: 1.5,
            dispersion: 0.0,
            transmission: 0.0,
            transmission_tex: None,
            volume: None,
            volume_factors: VolumeFactors::default(),
            clearcoat: 0.0,
            clearcoat_tex: None,
            clearcoat_roughness: 0.0,
            clearcoat_roughness_tex: None,
            clearcoat_normal_tex: None,
            clearcoat_normal_scale: 1.0,
            anisotropy_strength: 0.0,
            anisotropy_rotation: 0.0,
            anisotropy_tex: None,
            iridescence: 0.0,
            iridescence_tex: None,
            iridescence_ior: 1.3,
            iridescence_thickness_min: 100.0,
            iridescence_thickness_max: 400.0,
            iridescence_thickness_tex: None,
            sheen_color: Vec3::ZERO,
            sheen_color_tex: None,
            sheen_roughness: 0.0,
            sheen_roughness_tex: None,
            diffuse_transmission: 0.0,
            diffuse_transmission_tex: None,
            diffuse_transmission_color: Vec3::ONE,
            diffuse_transmission_color_tex: None,
            measured: None,
        }
    }
}

impl Material {
    /// A purely Lambertian material (no specular layer) of the given albedo.
    pub fn lambert(name: &str, albedo: Vec3) -> Self {
        Self { name: name.into(), base_color: albedo, metallic: 0.0, specular: 0.0, ..Self::default() }
    }

    /// A smooth glass of index `ior` (a refracting volume with absorption `sigma_a`, or
    /// thin-walled if None).
    pub fn glass(name: &str, ior: f32, sigma_a: Option<Vec3>) -> Self {
        Self::dielectric(name, ior, sigma_a.map(Volume::absorbing))
    }

    /// A smooth, clear dielectric boundary of index `ior` around `volume` (thin-walled if None);
    /// with ior 1 it is index-matched: light crosses it unchanged.
    pub fn dielectric(name: &str, ior: f32, volume: Option<Volume>) -> Self {
        Self { name: name.into(), metallic: 0.0, roughness: 0.0, transmission: 1.0, ior, volume, ..Self::default() }
    }

    /// Whether a thin film (KHR_materials_iridescence) coats the surface.
    pub fn is_iridescent(&self) -> bool {
        self.iridescence > 0.0
    }

    /// Whether the index of refraction varies with wavelength where light crosses.
    pub fn is_dispersive(&self) -> bool {
        self.dispersion > 0.0
            && self.volume.is_some()
            && self.transmission > 0.0
            && self.metallic < 1.0
            && self.ior != 1.0
    }

    /// Index of refraction at `lambda` nm (KHR_materials_dispersion): n_d + (n_d - 1) / V_d
    /// (523655 / lambda^2 - 1.5168), at least 1, with V_d = 20 / dispersion.
    pub fn ior_at(&self, lambda: f32) -> f32 {
        if self.dispersion <= 0.0 {
            return self.ior;
        }
        let abbe = 20.0 / self.dispersion;
        (self.ior + (self.ior - 1.0) / abbe * (523_655.0 / (lambda * lambda) - 1.5168)).max(1.0)
    }

    /// Whether the BSDF has more than a Lambertian lobe.
    pub fn is_glossy(&self) -> bool {
        self.metallic > 0.0
            || self.specular > 0.0
            || self.is_transmissive()
            || self.clearcoat > 0.0
            || self.sheen_color.max_element() > 0.0
    }

    /// Whether light may pass through (KHR_materials_transmission on what is not all metal;
    /// the metal-rough texture can make a metallic factor of 1 less). Measured BRDFs only
    /// reflect.
    pub fn is_transmissive(&self) -> bool {
        self.measured.is_none()
            && (self.transmission > 0.0 || self.diffuse_transmission > 0.0)
            && (self.metallic < 1.0 || self.metallic_roughness_tex.is_some())
    }

    /// Whether light may leave through its surface straight on, by a null lobe: through a
    /// smooth thin wall, or an interface whose index matches the other side's, one of
    /// `outside_iors` (vacuum's and the other volumes'). Conservative: a texture that can
    /// lower the roughness counts as smooth, and a dispersive index as matching. Where no
    /// material may, shadow rays need no more than an occlusion query.
    pub fn may_pass_straight(&self, outside_iors: &[f32]) -> bool {
        if !self.is_transmissive() || self.transmission <= 0.0 {
            return false;
        }
        // Twice the BSDF's tolerance (`is_index_matched`), so that rounding cannot tell them
        // apart.
        let near = |eta: f32| (eta - 1.0).abs() < 2.0 * crate::bsdf::MATCHED_ETA;
        let matches = |a: f32, b: f32| near(a / b) || near(b / a);
        let ior = self.ior.max(1e-3);
        let matched = |outside: &[f32]| self.is_dispersive() || outside.iter().any(|&o| matches(ior, o));
        match self.volume {
            None => {
                let may_be_smooth = self.metallic_roughness_tex.is_some()
                    || crate::bsdf::is_smooth((self.roughness * self.roughness).clamp(0.0, 1.0));
                may_be_smooth || matched(&[1.0])
            }
            Some(_) => matched(outside_iors),
        }
    }

    /// Whether paths that cross the surface enter a refracting, absorbing volume.
    pub fn is_volume(&self) -> bool {
        self.is_transmissive() && self.volume.is_some()
    }

    /// Whether its volume scatters light (a participating medium).
    pub fn is_scattering(&self) -> bool {
        self.is_volume() && self.volume.is_some_and(|v| v.scatters())
    }

    /// Emitted radiance (linear RGB) before the emissive texture: emissiveFactor x emissiveStrength.
    pub fn emitted(&self) -> Vec3 {
        self.emissive * self.emissive_strength
    }

    /// Whether the material emits light (an unlit material shows its colour as if it did).
    pub fn is_emissive(&self) -> bool {
        self.emitted().max_element() > 0.0 || self.unlit
    }

    /// Makes `volume` the medium of `volume_factors`, unless it is a density grid (which the
    /// media sidecar gives, not the file's factors).
    pub fn update_volume(&mut self) {
        if self.volume.is_none_or(|v| v.grid.is_none()) {
            self.volume = self.volume_factors.medium();
        }
    }

    /// Whether its BSDF needs the surface's tangents: for its normal map, its anisotropy
    /// direction or its clearcoat's normal map.
    pub fn needs_tangents(&self) -> bool {
        self.normal_tex.is_some()
            || self.anisotropy_strength > 0.0
            || (self.clearcoat > 0.0 && self.clearcoat_normal_tex.is_some())
    }

    /// Whether rays may pass through some of its points without interacting (alpha), or
    /// through its back side (single-sided).
    pub fn is_cutout(&self) -> bool {
        self.alpha_mode != AlphaMode::Opaque || !self.double_sided
    }

    /// Whether the camera sees through this surface from the back (glTF's single-sided
    /// materials are culled there; volumes never are): a camera looking along `d` at a
    /// facet of geometric normal `ng`.
    pub fn culled_from(&self, d: Vec3, ng: Vec3) -> bool {
        !self.double_sided && !self.is_volume() && d.dot(ng) > 0.0
    }

    /// The textures its slots read: those of `MATERIAL_PARAMS`' entries.
    fn textures(&self) -> impl Iterator<Item = TexRef> + '_ {
        MATERIAL_PARAMS.iter().filter_map(|p| (p.texture.as_ref()?.get)(self))
    }

    /// Whether any of its slots reads a texture.
    pub fn is_textured(&self) -> bool {
        self.textures().next().is_some()
    }

    /// Whether any slot reads TEXCOORD_1.
    pub fn uses_second_uv_set(&self) -> bool {
        self.textures().any(|t| t.set == 1)
    }

    /// Opacity at a surface point: alpha factor x texture alpha x vertex colour alpha.
    pub fn opacity(&self, textures: &[Texture], images: &[Image], surface: &Surface) -> f32 {
        let tex = self.base_color_tex.map_or(1.0, |t| t.sample(textures, images, &surface.uv, ColorSpace::Srgb).w);
        self.alpha * tex * surface.color.w
    }

    /// The BSDF at a surface point in the shading `frame`, seen from its front (`front`) or
    /// back side, with `outside_ior` the index of the medium on the side away from this
    /// material's volume. `basis` gives the interpolated tangent and the interpolated normal
    /// before normal mapping (asked for only by the two things that need them): an
    /// anisotropic material turns the frame about its normal so that +x is the anisotropy
    /// direction the tangent places, and a clearcoat with its own normal map, or under a
    /// mapped base, gets its normal from them (`clearcoat_normal`).
    /// Colours become spectra here (`Spectrum::from_rgb`); GGX alphas below
    /// `bsdf::SMOOTH_ALPHA` become delta lobes in the BSDF. `features` are the scene's: in
    /// a scene without textures or glossy lobes their checks are skipped.
    #[inline]
    pub fn bsdf(
        &self,
        scene: SceneRefs<'_>,
        surface: &Surface,
        (frame, basis): (&mut Frame, impl FnOnce() -> (Vec4, Vec3)),
        (front, outside_ior): (bool, f32),
        wavelength: Option<f32>,
    ) -> Bsdf<'_> {
        let SceneRefs { textures, images, features } = scene;
        if let Some(m) = &self.measured {
            return Bsdf::Measured(&m.table);
        }
        if self.unlit {
            return Bsdf::Lambert(Lambert { albedo: Spectrum::ZERO });
        }
        let mut base = self.base_color * surface.color.xyz();
        let lookup = |t: Option<TexRef>, space| {
            t.filter(|_| features.textures).map(|t| t.sample(textures, images, &surface.uv, space))
        };
        if let Some(c) = lookup(self.base_color_tex, ColorSpace::Srgb) {
            base *= c.xyz();
        }
        if !(features.glossy && self.is_glossy()) {
            return Bsdf::Lambert(Lambert { albedo: Spectrum::from_rgb(base) });
        }
        let (mut metallic, mut roughness) = (self.metallic, self.roughness);
        if let Some(mr) = lookup(self.metallic_roughness_tex, ColorSpace::Linear) {
            roughness *= mr.y;
            metallic *= mr.z;
        }
        let specular = self.specular * lookup(self.specular_tex, ColorSpace::Linear).map_or(1.0, |t| t.w);
        let specular_color =
            self.specular_color * lookup(self.specular_color_tex, ColorSpace::Srgb).map_or(Vec3::ONE, |t| t.xyz());
        let transmission = self.transmission * lookup(self.transmission_tex, ColorSpace::Linear).map_or(1.0, |t| t.x);
        let clearcoat = self.clearcoat * lookup(self.clearcoat_tex, ColorSpace::Linear).map_or(1.0, |t| t.x);
        let clearcoat_roughness =
            self.clearcoat_roughness * lookup(self.clearcoat_roughness_tex, ColorSpace::Linear).map_or(1.0, |t| t.y);
        let sheen = self.sheen_color * lookup(self.sheen_color_tex, ColorSpace::Srgb).map_or(Vec3::ONE, |t| t.xyz());
        let sheen_roughness =
            self.sheen_roughness * lookup(self.sheen_roughness_tex, ColorSpace::Linear).map_or(1.0, |t| t.w);
        let diffuse_transmission =
            self.diffuse_transmission * lookup(self.diffuse_transmission_tex, ColorSpace::Linear).map_or(1.0, |t| t.w);
        let diffuse_transmission_color = self.diffuse_transmission_color
            * lookup(self.diffuse_transmission_color_tex, ColorSpace::Srgb).map_or(Vec3::ONE, |t| t.xyz());
        let ior = match wavelength {
            Some(lambda) if self.is_dispersive() => self.ior_at(lambda),
            _ => self.ior,
        };
        let f0 = ((ior - 1.0) / (ior + 1.0)).powi(2);
        let ior = ior.max(1e-3);
        let eta = match (self.volume, front) {
            (None, _) => ior,
            (Some(_), true) => ior / outside_ior,
            (Some(_), false) => outside_ior / ior,
        };
        let alpha = |r: f32| (r * r).clamp(0.0, 1.0);
        let mut anisotropy = self.anisotropy_strength;
        let coat_mapped = clearcoat > 0.0 && (self.clearcoat_normal_tex.is_some() || self.normal_tex.is_some());
        let basis = (anisotropy > 0.0 || coat_mapped).then(basis);
        if let Some((tangent, _)) = basis.filter(|_| anisotropy > 0.0) {
            let texel = lookup(self.anisotropy_tex, ColorSpace::Linear);
            let direction = texel.map_or(Vec2::X, |t| (t.xy() * 2.0 - 1.0).normalize_or(Vec2::X));
            anisotropy *= texel.map_or(1.0, |t| t.z);
            *frame = frame.aligned(self.anisotropy_axis(surface.ns, tangent, direction));
        }
        let clearcoat_normal = match basis.filter(|_| coat_mapped) {
            Some(basis) => {
                let map = lookup(self.clearcoat_normal_tex, ColorSpace::Linear);
                self.clearcoat_normal(frame, basis, map, front)
            }
            None => Vec3::Z,
        };
        let iridescence = self.iridescence * lookup(self.iridescence_tex, ColorSpace::Linear).map_or(1.0, |t| t.x);
        let (thin, thick) = (self.iridescence_thickness_min, self.iridescence_thickness_max);
        let film_thickness =
            lookup(self.iridescence_thickness_tex, ColorSpace::Linear).map_or(thick, |t| thin + (thick - thin) * t.y);
        Bsdf::MetalRough(MetalRough {
            base: Spectrum::from_rgb(base.clamp(Vec3::ZERO, Vec3::ONE)),
            metallic: metallic.clamp(0.0, 1.0),
            alpha: alpha(roughness),
            anisotropy: anisotropy.clamp(0.0, 1.0),
            // KHR_materials_specular clamps only the product: a colour factor above 1 raises
            // F0 up to 1 (a factor of 25 on F0 = 0.04 makes a mirror).
            dielectric_f0: Spectrum::from_rgb((f0 * specular_color).min(Vec3::ONE)),
            specular: specular.clamp(0.0, 1.0),
            // The refracting interface's reflection, whose Fresnel term is exact, keeps a tint
            // of at most 1, so that it never reflects more than arrives.
            specular_tint: Spectrum::from_rgb(specular_color.min(Vec3::ONE)),
            transmission: transmission.clamp(0.0, 1.0),
            eta,
            thin: self.volume.is_none(),
            clearcoat: clearcoat.clamp(0.0, 1.0),
            clearcoat_alpha: alpha(clearcoat_roughness),
            clearcoat_normal,
            iridescence: iridescence.clamp(0.0, 1.0),
            film_ior: self.iridescence_ior,
            film_thickness: film_thickness.max(0.0),
            film_wavelength: wavelength.filter(|_| iridescence > 0.0),
            sheen: Spectrum::from_rgb(sheen.clamp(Vec3::ZERO, Vec3::ONE)),
            sheen_alpha: (sheen_roughness * sheen_roughness).clamp(MIN_SHEEN_ALPHA, 1.0),
            diffuse_transmission: diffuse_transmission.clamp(0.0, 1.0),
            diffuse_transmission_color: Spectrum::from_rgb(diffuse_transmission_color.clamp(Vec3::ZERO, Vec3::ONE)),
        })
    }

    /// The clearcoat's normal in `frame` (its normal on the side seen, `front` or not): the
    /// interpolated normal of `(tangent, normal)` perturbed by the clearcoat normal map's
    /// `texel` (glTF convention: RGB in [0, 1] to [-1, 1], X and Y times the scale), or left
    /// unperturbed without one. +z where it would face away from the frame's normal.
    fn clearcoat_normal(
        &self,
        frame: &Frame,
        (tangent, normal): (Vec4, Vec3),
        texel: Option<Vec4>,
        front: bool,
    ) -> Vec3 {
        let scale = Vec3::new(self.clearcoat_normal_scale, self.clearcoat_normal_scale, 1.0);
        let world = match texel {
            Some(t) => super::surface::normal_mapped(normal, tangent, (t.xyz() * 2.0 - 1.0) * scale),
            None => normal,
        };
        let local = frame.to_local(if front { world } else { -world }).normalize_or_zero();
        if local.z > 0.0 { local } else { Vec3::Z }
    }

    /// World direction of the anisotropy: the tangent-space `direction` turned by
    /// anisotropyRotation, in the frame of `tangent`, the bitangent (sign x n x t) and the
    /// shading normal `n`. Zero without tangents (the frame then stays as it is).
    fn anisotropy_axis(&self, n: Vec3, tangent: Vec4, direction: Vec2) -> Vec3 {
        let (sin, cos) = self.anisotropy_rotation.sin_cos();
        let d = Vec2::new(cos * direction.x - sin * direction.y, sin * direction.x + cos * direction.y);
        let t = tangent.xyz();
        let sign = if tangent.w < 0.0 { -1.0 } else { 1.0 };
        t * d.x + sign * n.cross(t) * d.y
    }

    /// What an unlit material shows: base colour x vertex colour x base colour texture. Kept
    /// out of line so that `emission`, on every light sample, stays small.
    #[cold]
    #[inline(never)]
    fn unlit_colour(&self, textures: &[Texture], images: &[Image], surface: &Surface) -> Spectrum {
        let tex = self.base_color_tex.map_or(Vec4::ONE, |t| t.sample(textures, images, &surface.uv, ColorSpace::Srgb));
        Spectrum::from_illuminant_rgb(self.base_color * surface.color.xyz() * tex.xyz())
    }

    /// The emitted radiance where it is the same all over the surface: neither textured
    /// nor unlit (whose colour follows the vertex colours and the base colour texture).
    pub fn uniform_emission(&self) -> Option<Spectrum> {
        (!self.unlit && self.emissive_tex.is_none()).then(|| Spectrum::from_illuminant_rgb(self.emitted()))
    }

    /// Emitted radiance at a surface point (the same from every direction on the front side).
    pub fn emission(&self, textures: &[Texture], images: &[Image], surface: &Surface) -> Spectrum {
        if self.unlit {
            return self.unlit_colour(textures, images, surface);
        }
        Spectrum::from_illuminant_rgb(match self.emissive_tex {
            Some(t) => self.emitted() * t.sample(textures, images, &surface.uv, ColorSpace::Srgb).xyz(),
            None => self.emitted(),
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn only_smooth_thin_walls_and_matched_indices_may_pass_light_straight() {
        let volume = Some(Volume::absorbing(Vec3::splat(0.1)));
        let vacuum = [1.0];
        // Refracting glass around a volume, alone or beside a volume of another index.
        assert!(!Material::dielectric("glass", 1.5, volume).may_pass_straight(&vacuum));
        assert!(!Material::dielectric("glass", 1.5, volume).may_pass_straight(&[1.0, 1.33]));
        // Index-matched: to vacuum, or to water beside it (either side of the interface).
        assert!(Material::dielectric("matched", 1.0, volume).may_pass_straight(&vacuum));
        assert!(Material::dielectric("water", 1.33, volume).may_pass_straight(&[1.0, 1.33]));
        assert!(Material::dielectric("water", 1.3305, volume).may_pass_straight(&[1.0, 1.33]));
        // Thin walls: smooth ones pass light straight, rough ones only at index 1.
        assert!(Material::dielectric("pane", 1.5, None).may_pass_straight(&vacuum));
        let frosted = Material { roughness: 0.5, ..Material::dielectric("frosted", 1.5, None) };
        assert!(!frosted.may_pass_straight(&vacuum));
        assert!(Material { ior: 1.0, ..frosted.clone() }.may_pass_straight(&vacuum));
        // A roughness texture may make it smooth somewhere; dispersion may match somewhere.
        let tex = Some(TexRef::plain(0));
        assert!(Material { metallic_roughness_tex: tex, ..frosted.clone() }.may_pass_straight(&vacuum));
        let flint = Material { dispersion: 0.5, ..Material::dielectric("flint", 1.6, volume) };
        assert!(flint.may_pass_straight(&vacuum));
        // What does not transmit by its specular interface never does.
        let leaf = Material { diffuse_transmission: 1.0, transmission: 0.0, ..frosted.clone() };
        assert!(!leaf.may_pass_straight(&vacuum));
        assert!(!Material { metallic: 1.0, ..Material::dielectric("metal", 1.0, None) }.may_pass_straight(&vacuum));
    }
}
